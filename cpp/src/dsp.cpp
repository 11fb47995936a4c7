#include "millscope/dsp.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace millscope::dsp {
namespace {

constexpr double pi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------
// FFTW plans, created once per length and reused. FFTW's planner is process-wide and not
// thread-safe, so this cache is the one piece of shared state here: creation is serialised by a
// mutex, execution uses the thread-safe new-array interface on buffers from fftw_malloc (which
// share the plan's alignment), so any number of threads may transform at once.
// ---------------------------------------------------------------------------------------------
struct FftwFree {
  void operator()(void* p) const { fftw_free(p); }
};
using RealBuffer = std::unique_ptr<double[], FftwFree>;
using ComplexBuffer = std::unique_ptr<fftw_complex[], FftwFree>;

RealBuffer real_buffer(std::size_t n) {
  return RealBuffer(static_cast<double*>(fftw_malloc(sizeof(double) * n)));
}
ComplexBuffer complex_buffer(std::size_t n) {
  return ComplexBuffer(static_cast<fftw_complex*>(fftw_malloc(sizeof(fftw_complex) * n)));
}

class RealFftPlans {
 public:
  explicit RealFftPlans(std::size_t n) : n_(n) {
    auto in = real_buffer(n);
    auto out = complex_buffer(n / 2 + 1);
    const int len = static_cast<int>(n);
    forward_ = fftw_plan_dft_r2c_1d(len, in.get(), out.get(), FFTW_ESTIMATE);
    inverse_ = fftw_plan_dft_c2r_1d(len, out.get(), in.get(), FFTW_ESTIMATE);
    if (forward_ == nullptr || inverse_ == nullptr) throw std::runtime_error("FFTW could not plan");
  }
  RealFftPlans(const RealFftPlans&) = delete;
  RealFftPlans& operator=(const RealFftPlans&) = delete;
  ~RealFftPlans() {
    fftw_destroy_plan(forward_);
    fftw_destroy_plan(inverse_);
  }
  // in: n reals; out: n/2+1 complex. Both from fftw_malloc.
  void forward(double* in, fftw_complex* out) const { fftw_execute_dft_r2c(forward_, in, out); }
  // Unnormalised inverse (returns n times the signal). Destroys `in`.
  void inverse(fftw_complex* in, double* out) const { fftw_execute_dft_c2r(inverse_, in, out); }
  std::size_t size() const { return n_; }

 private:
  std::size_t n_;
  fftw_plan forward_;
  fftw_plan inverse_;
};

const RealFftPlans& plans_for(std::size_t n) {
  static std::mutex planner_mutex;
  static std::map<std::size_t, std::unique_ptr<const RealFftPlans>> cache;
  std::lock_guard<std::mutex> lock(planner_mutex);
  auto& slot = cache[n];
  if (!slot) slot = std::make_unique<const RealFftPlans>(n);
  return *slot;
}

void require_block(std::size_t n, double fs) {
  if (n < 4) {
    throw std::invalid_argument("block has " + std::to_string(n) +
                                " samples; spectral analysis needs at least 4");
  }
  if (!(fs > 0.0) || !std::isfinite(fs)) {
    std::ostringstream msg;
    msg << "sample rate fs = " << fs << " Hz is not valid; it must be finite and > 0";
    throw std::invalid_argument(msg.str());
  }
}

// Two-sided multiplicity of single-sided bin k: DC and (even N) Nyquist appear once, others twice.
double two_sided_weight(std::size_t k, std::size_t n) {
  return (k == 0 || (n % 2 == 0 && k == n / 2)) ? 1.0 : 2.0;
}

double mean_of(const double* x, std::size_t n) {
  return std::accumulate(x, x + n, 0.0) / static_cast<double>(n);
}

// X_k of w * (x - offset), k = 0 .. n/2.
std::vector<cplx> rfft_of_windowed(const double* x, std::size_t n, Window window, double offset) {
  const auto w = window_samples(window, n);
  const auto& plans = plans_for(n);
  auto in = real_buffer(n);
  auto out = complex_buffer(n / 2 + 1);
  for (std::size_t i = 0; i < n; ++i) in[i] = w[i] * (x[i] - offset);
  plans.forward(in.get(), out.get());
  std::vector<cplx> result(n / 2 + 1);
  for (std::size_t k = 0; k < result.size(); ++k) result[k] = cplx(out[k][0], out[k][1]);
  return result;
}

// |sum_n w(n) y(n) exp(-2 pi i f n / fs)|: the windowed DTFT magnitude at any frequency f.
// The phasor advances by one complex product a sample and is set afresh from cos and sin at
// the start of every run of kPhasorRun samples, which bounds its rounding drift to a few
// hundred ulps whatever the block's length.
double dtft_magnitude(const std::vector<double>& wy, double f, double fs) {
  constexpr std::size_t kPhasorRun = 256;
  const double step = -2.0 * pi * f / fs;
  const double turn_re = std::cos(step), turn_im = std::sin(step);
  double sum_re = 0.0, sum_im = 0.0;
  for (std::size_t start = 0; start < wy.size(); start += kPhasorRun) {
    const double phase = step * static_cast<double>(start);
    double re = std::cos(phase), im = std::sin(phase);
    const std::size_t end = std::min(wy.size(), start + kPhasorRun);
    for (std::size_t i = start; i < end; ++i) {
      sum_re += wy[i] * re;
      sum_im += wy[i] * im;
      const double next_re = re * turn_re - im * turn_im;
      im = re * turn_im + im * turn_re;
      re = next_re;
    }
  }
  return std::hypot(sum_re, sum_im);
}

}  // namespace

Window window_from_name(const std::string& name) {
  if (name == "hann") return Window::hann;
  if (name == "hann_periodic") return Window::hann_periodic;
  if (name == "rectangular" || name == "boxcar") return Window::rectangular;
  throw std::invalid_argument("window = '" + name +
                              "' is not known; use 'hann', 'hann_periodic' or 'rectangular'");
}

std::string window_name(Window window) {
  switch (window) {
    case Window::hann: return "hann";
    case Window::hann_periodic: return "hann_periodic";
    case Window::rectangular: return "rectangular";
  }
  return "?";
}

std::vector<double> window_samples(Window window, std::size_t n) {
  std::vector<double> w(n, 1.0);
  if (window == Window::rectangular || n < 2) return w;
  // eq. (10): w(n) = sin^2(pi n / (N - 1)) for the symmetric form; N in place of N - 1 for periodic.
  const double period = window == Window::hann ? static_cast<double>(n - 1) : static_cast<double>(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = std::sin(pi * static_cast<double>(i) / period);
    w[i] = s * s;
  }
  return w;
}

WindowFactors window_factors(Window window, std::size_t n) {
  if (n == 0) throw std::invalid_argument("window length n = 0; it must be >= 1");
  const auto w = window_samples(window, n);
  double sum = 0.0, sum_sq = 0.0;
  for (double v : w) {
    sum += v;
    sum_sq += v * v;
  }
  const double len = static_cast<double>(n);
  return WindowFactors{sum / len, sum_sq / len, len * sum_sq / (sum * sum),
                       window == Window::rectangular ? 1.0 : 2.0};
}

std::vector<double> bin_frequencies(std::size_t n, double fs) {
  std::vector<double> f(n / 2 + 1);
  for (std::size_t k = 0; k < f.size(); ++k) f[k] = static_cast<double>(k) * fs / static_cast<double>(n);
  return f;
}

std::vector<cplx> windowed_rfft(const double* x, std::size_t n, Window window) {
  require_block(n, 1.0);
  return rfft_of_windowed(x, n, window, 0.0);
}

Spectra spectra(const double* x, std::size_t n, double fs, Window window) {
  require_block(n, fs);
  const auto X = rfft_of_windowed(x, n, window, 0.0);
  const auto w = window_samples(window, n);
  double sum = 0.0, sum_sq = 0.0;
  for (double v : w) {
    sum += v;
    sum_sq += v * v;
  }
  Spectra s{std::vector<double>(X.size()), std::vector<double>(X.size()),
            std::vector<double>(X.size())};
  for (std::size_t k = 0; k < X.size(); ++k) {
    const double mag2 = std::norm(X[k]);
    const double weight = two_sided_weight(k, n);
    s.amplitude[k] = weight * std::sqrt(mag2) / sum;
    s.power[k] = weight * mag2 / (sum * sum);
    s.psd[k] = weight * mag2 / (fs * sum_sq);
  }
  return s;
}

Peak find_peak(const double* x, std::size_t n, double fs, Window window, double near_hz,
               double search_hz) {
  require_block(n, fs);
  const double nyquist = fs / 2.0;
  if (!(near_hz >= 0.0 && near_hz <= nyquist)) {
    std::ostringstream msg;
    msg << "near_hz = " << near_hz << " Hz is outside the spectrum, [0, " << nyquist << "] Hz";
    throw std::invalid_argument(msg.str());
  }
  if (!(search_hz >= 0.0) || !std::isfinite(search_hz)) {
    std::ostringstream msg;
    msg << "search_hz = " << search_hz << " Hz is not valid; it must be finite and >= 0";
    throw std::invalid_argument(msg.str());
  }
  const double df = fs / static_cast<double>(n);
  const std::size_t last = n / 2;
  const double mean = mean_of(x, n);
  const auto X = rfft_of_windowed(x, n, window, mean);

  // The bins inside [lo, hi], counted from the frequencies directly: a bin index computed as
  // (k df) / df may round to k - 1 and widen the window by a bin.
  const double lo = std::max(0.0, near_hz - search_hz), hi = std::min(nyquist, near_hz + search_hz);
  const double slack = 1e-9;  // in bins: a bin on the window's edge counts as inside it
  auto clamp_bin = [&](double k) {
    return static_cast<std::size_t>(std::clamp(k, 0.0, static_cast<double>(last)));
  };
  std::size_t k_lo = clamp_bin(std::ceil(lo / df - slack));
  std::size_t k_hi = clamp_bin(std::floor(hi / df + slack));
  if (k_lo > k_hi) k_lo = k_hi = clamp_bin(std::round(near_hz / df));  // window within a bin
  // The largest bin of the window that is a peak of the spectrum (no larger than either
  // neighbour, inside the window or not); else the largest bin: the slope of a line outside.
  auto power = [&](std::size_t k) { return std::norm(X[k]); };
  auto is_peak = [&](std::size_t k) {
    return (k == 0 || power(k) >= power(k - 1)) && (k == last || power(k) >= power(k + 1));
  };
  std::size_t best = k_lo, best_peak = k_hi + 1;
  for (std::size_t k = k_lo; k <= k_hi; ++k) {
    if (power(k) > power(best)) best = k;
    if (is_peak(k) && (best_peak > k_hi || power(k) > power(best_peak))) best_peak = k;
  }
  if (best_peak <= k_hi) best = best_peak;

  // Refine by golden-section search on the windowed DTFT between the neighbouring bins, within
  // the asked window: a larger line just outside it cannot draw the result out of it.
  const auto w = window_samples(window, n);
  std::vector<double> wy(n);
  double sum_w = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    wy[i] = w[i] * (x[i] - mean);
    sum_w += w[i];
  }
  const double kb = static_cast<double>(best);
  const double a0 = std::max((kb - 1.0) * df, lo);
  const double b0 = std::min((kb + 1.0) * df, hi);
  double a = a0, b = b0;
  const double inv_phi = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = b - inv_phi * (b - a), d = a + inv_phi * (b - a);
  double fc = dtft_magnitude(wy, c, fs), fd = dtft_magnitude(wy, d, fs);
  // Each iteration shrinks the bracket by 1/phi: 60 take two bins below 1e-12 of a bin, as
  // far as a double resolves a frequency. The count bounds the loop where rounding stops the
  // bracket from shrinking (very long blocks).
  const double tolerance = std::max(1e-9 * df, 8.0 * std::numeric_limits<double>::epsilon() * b);
  for (int iteration = 0; iteration < 100 && b - a > tolerance; ++iteration) {
    if (fc > fd) {
      b = d; d = c; fd = fc;
      c = b - inv_phi * (b - a);
      fc = dtft_magnitude(wy, c, fs);
    } else {
      a = c; c = d; fc = fd;
      d = a + inv_phi * (b - a);
      fd = dtft_magnitude(wy, d, fs);
    }
  }
  const double f_peak = 0.5 * (a + b);
  const double peak = dtft_magnitude(wy, f_peak, fs);
  auto gain = [&](double f) {  // single-sided amplitude per |DTFT|
    return ((f < 0.5 * df || f > nyquist - 0.5 * df) ? 1.0 : 2.0) / sum_w;
  };
  // A local maximum of the spectrum, unless the search ended on an edge of the window that
  // is not an edge of the spectrum and the spectrum still rises beyond it.
  const double step = 1e-3 * df;
  const bool low_edge = a0 == lo && lo > 0.0 && f_peak - a0 < 2.0 * tolerance &&
                        dtft_magnitude(wy, a0 - step, fs) > peak;
  const bool high_edge = b0 == hi && hi < nyquist && b0 - f_peak < 2.0 * tolerance &&
                         dtft_magnitude(wy, b0 + step, fs) > peak;

  // The noise around the line: the median amplitude of the bins within kNoiseBins of it,
  // outside its main lobe (with a bin to spare) and outside the mean's.
  const auto lobe = static_cast<std::size_t>(window_factors(window, n).mainlobe_half_bins) + 1;
  std::vector<double> around;
  const std::size_t from = best > kNoiseBins ? best - kNoiseBins : 0;
  const std::size_t to = std::min(last, best + kNoiseBins);
  for (std::size_t k = from; k <= to; ++k) {
    const std::size_t gap = k > best ? k - best : best - k;
    if (gap > lobe && k > lobe) around.push_back(std::abs(X[k]) * gain(static_cast<double>(k) * df));
  }
  double noise = 0.0;
  if (!around.empty()) {
    auto mid = around.begin() + static_cast<std::ptrdiff_t>(around.size() / 2);
    std::nth_element(around.begin(), mid, around.end());
    noise = *mid;
  }
  return Peak{f_peak, gain(f_peak) * peak, best, noise, !(low_edge || high_edge)};
}

BandMask band_mask(std::size_t n, double fs, Window window, bool remove_mean,
                   const std::vector<double>& lines_hz, double bandwidth_hz, double band_lo_hz,
                   double band_hi_hz) {
  require_block(n, fs);
  const double nyquist = fs / 2.0;
  if (!(bandwidth_hz >= 0.0) || !std::isfinite(bandwidth_hz)) {
    std::ostringstream msg;
    msg << "bandwidth = " << bandwidth_hz << " Hz is not valid; it must be finite and >= 0";
    throw std::invalid_argument(msg.str());
  }
  if (!(band_lo_hz >= 0.0 && band_hi_hz > band_lo_hz && band_lo_hz <= nyquist)) {
    std::ostringstream msg;
    msg << "band = (" << band_lo_hz << ", " << band_hi_hz << ") Hz is not valid; it needs "
        << "0 <= low < high with low <= Nyquist = " << nyquist << " Hz";
    throw std::invalid_argument(msg.str());
  }
  for (double f : lines_hz) {
    if (!(f >= 0.0 && f <= nyquist)) {
      std::ostringstream msg;
      msg << "line to remove at " << f << " Hz is outside the spectrum, [0, " << nyquist << "] Hz";
      throw std::invalid_argument(msg.str());
    }
  }
  const double df = fs / static_cast<double>(n);
  const double lobe = window_factors(window, n).mainlobe_half_bins * df;

  BandMask mask;
  mask.half_width_hz = bandwidth_hz / 2.0;
  mask.widened = false;
  mask.subtract_mean = remove_mean;
  if (remove_mean) mask.centres_hz.push_back(0.0);
  mask.centres_hz.insert(mask.centres_hz.end(), lines_hz.begin(), lines_hz.end());
  if (!mask.centres_hz.empty() && mask.half_width_hz < lobe) {
    mask.half_width_hz = lobe;
    mask.widened = true;
  }
  const double tol = 1e-9 * df;
  const std::size_t bins = n / 2 + 1;
  mask.keep.assign(bins, 1);
  double kept_weight = 0.0;
  for (std::size_t k = 0; k < bins; ++k) {
    const double f = static_cast<double>(k) * df;
    bool keep = f >= band_lo_hz - tol && f <= band_hi_hz + tol;
    for (double c : mask.centres_hz)
      if (std::abs(f - c) <= mask.half_width_hz + tol) keep = false;
    mask.keep[k] = keep ? 1 : 0;
    if (keep) kept_weight += two_sided_weight(k, n);
  }
  mask.fraction_kept = kept_weight / static_cast<double>(n);
  return mask;
}

namespace {
// The masked windowed spectrum; subtracts the block mean first when the mean is to be removed,
// which keeps a large DC term from leaking into neighbouring bins.
std::vector<cplx> masked_spectrum(const double* x, std::size_t n, Window window,
                                  const BandMask& mask) {
  if (mask.keep.size() != n / 2 + 1)
    throw std::invalid_argument("band mask was made for another block length");
  auto X = rfft_of_windowed(x, n, window, mask.subtract_mean ? mean_of(x, n) : 0.0);
  for (std::size_t k = 0; k < X.size(); ++k)
    if (!mask.keep[k]) X[k] = 0.0;
  return X;
}
}  // namespace

EnergyEstimate spectral_energy(const double* x, std::size_t n, double fs, Window window,
                               const BandMask& mask) {
  require_block(n, fs);
  const auto X = masked_spectrum(x, n, window, mask);
  double sum_w2 = 0.0, sum_w4 = 0.0;
  for (double v : window_samples(window, n)) {
    sum_w2 += v * v;
    sum_w4 += v * v * v * v;
  }
  double two_sided = 0.0, single = 0.0, single_sq = 0.0;
  for (std::size_t k = 0; k < X.size(); ++k) {
    const double p = std::norm(X[k]);
    two_sided += two_sided_weight(k, n) * p;
    single += p;
    single_sq += p * p;
  }
  const double c_w = static_cast<double>(n) * sum_w4 / (sum_w2 * sum_w2);
  // |X_k|^2 of Gaussian noise is exponential, E[P^2] = 2 E[P]^2: half the sum of P_k^2
  // estimates sum (E P_k)^2.
  const double relative_std = single > 0.0 ? std::sqrt(c_w * single_sq / 2.0) / single : 0.0;
  return EnergyEstimate{two_sided / (fs * sum_w2),  // eq. (11) by Parseval, window power corrected
                        relative_std};
}

std::vector<double> band_stop(const double* x, std::size_t n, Window window,
                              const BandMask& mask) {
  require_block(n, 1.0);
  const auto X = masked_spectrum(x, n, window, mask);
  const auto& plans = plans_for(n);
  auto in = complex_buffer(n / 2 + 1);
  auto out = real_buffer(n);
  for (std::size_t k = 0; k < X.size(); ++k) {
    in[k][0] = X[k].real();
    in[k][1] = X[k].imag();
  }
  plans.inverse(in.get(), out.get());
  const double power_gain = window_factors(window, n).power_gain;
  const double scale = 1.0 / (static_cast<double>(n) * std::sqrt(power_gain));
  std::vector<double> y(n);
  for (std::size_t i = 0; i < n; ++i) y[i] = out[i] * scale;
  return y;
}

std::string fftw_version() { return ::fftw_version; }

}  // namespace millscope::dsp
