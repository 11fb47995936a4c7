// MILLSCOPE_HOT_INLINE: a function the step's hot loops call that the compiler must inline
// (GCC and Clang), where it would otherwise keep a large function out of line and pay a call
// per contact or per particle.
#pragma once

#if defined(__GNUC__)
#define MILLSCOPE_HOT_INLINE inline __attribute__((always_inline))
#else
#define MILLSCOPE_HOT_INLINE inline
#endif
