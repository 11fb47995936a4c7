// Spectral analysis of torque records (paper sections 3.2 and 6.2-6.4; docs/architecture.md,
// Spectra).
//
// Conventions: x is a block of N uniformly spaced real samples taken at fs hertz, so the block
// length is TR = N / fs seconds and the resolution df = 1 / TR (eq. 9). Every spectrum is the FFT of
// the windowed block, X_k = sum_n w(n) x(n) exp(-2 pi i k n / N), k = 0 .. N/2 (single-sided).
#pragma once

#include <complex>
#include <cstddef>
#include <string>
#include <vector>

namespace millscope::dsp {

using cplx = std::complex<double>;

enum class Window {
  hann,           // symmetric Hann, w(n) = sin^2(pi n / (N - 1))            (eq. 10)
  hann_periodic,  // periodic Hann,  w(n) = sin^2(pi n / N)
  rectangular,    // w(n) = 1
};

/// Parses "hann", "hann_periodic" or "rectangular"; throws std::invalid_argument otherwise.
Window window_from_name(const std::string& name);
std::string window_name(Window window);

/// The N window samples w(0) .. w(N-1).
std::vector<double> window_samples(Window window, std::size_t n);

/// Gains of a window of N samples.
struct WindowFactors {
  double coherent_gain;      // sum(w) / N: the amplitude a sinusoid keeps at its bin
  double power_gain;         // sum(w^2) / N: the power broadband noise keeps
  double enbw_bins;          // equivalent noise bandwidth N sum(w^2) / sum(w)^2, in bins
  double mainlobe_half_bins; // half-width of the main lobe, in bins (Hann 2, rectangular 1)
};
WindowFactors window_factors(Window window, std::size_t n);

/// Single-sided spectra of one windowed block, k = 0 .. N/2; power and psd match
/// scipy.signal.periodogram's scaling="spectrum" and scaling="density".
struct Spectra {
  std::vector<double> amplitude;  // 2|X_k| / sum(w) (|X_k| / sum(w) at DC and Nyquist): a
                                  // sinusoid of amplitude A reads A
  std::vector<double> power;      // squared RMS per bin, 2|X_k|^2 / sum(w)^2 (unit^2)
  std::vector<double> psd;        // power spectral density, 2|X_k|^2 / (fs sum(w^2)) (unit^2/Hz)
};

/// Frequencies of the N/2 + 1 single-sided bins, k fs / N, in Hz.
std::vector<double> bin_frequencies(std::size_t n, double fs);

/// The single-sided FFT X_k (k = 0 .. N/2) of the windowed block.
std::vector<cplx> windowed_rfft(const double* x, std::size_t n, Window window);

/// The three single-sided scalings of the windowed block, from one FFT.
Spectra spectra(const double* x, std::size_t n, double fs, Window window);

/// How many bins on each side of a located line give the noise level it is compared with.
inline constexpr std::size_t kNoiseBins = 25;

/// A spectral line located near an expected frequency.
struct Peak {
  double frequency_hz;     // refined between bins, always inside the search window
  double amplitude;        // amplitude of the sinusoid at frequency_hz, window gain corrected
  std::size_t bin;         // the largest bin in the search window
  double noise_amplitude;  // median amplitude of the bins within kNoiseBins of `bin`, outside
                           // its main lobe and the mean's (0 when there are none)
  bool local_maximum;      // false when the largest value in the window lies on its edge and
                           // the spectrum rises beyond it: a line outside, not one inside
};

/// Locates the largest line within [near_hz - search_hz, near_hz + search_hz] and refines it
/// between bins by maximising the magnitude of the windowed discrete-time Fourier transform of the
/// block (mean removed) over the neighbouring bins, never beyond the window. Exact for a lone
/// sinusoid whatever the window.
Peak find_peak(const double* x, std::size_t n, double fs, Window window, double near_hz,
               double search_hz);

/// Which bins a spectral-energy figure keeps.
struct BandMask {
  std::vector<unsigned char> keep;  // one flag per single-sided bin
  double half_width_hz;             // half-width actually removed around each line
  bool widened;                     // true when the requested bandwidth was below the main lobe
  double fraction_kept;             // kept share of the two-sided bins: sum of kept weights / N
  std::vector<double> centres_hz;   // the centres of the removed bands (0 for the mean)
  bool subtract_mean;               // the block mean is subtracted before windowing
};

/// Removes `remove_mean` (a band at 0 Hz) and a band of full width `bandwidth_hz` centred on each
/// of `lines_hz`; keeps only bins inside [band_lo_hz, band_hi_hz]. A band narrower than the
/// window's main lobe is widened to it, since a narrower one leaves most of the line in place.
BandMask band_mask(std::size_t n, double fs, Window window, bool remove_mean,
                   const std::vector<double>& lines_hz, double bandwidth_hz, double band_lo_hz,
                   double band_hi_hz);

/// Energy of a filtered block and its sampling spread.
struct EnergyEstimate {
  double energy;        // unit^2 s
  double relative_std;  // standard deviation of the estimate over its mean, for a Gaussian
                        // signal whose spectrum is smooth across a main lobe
};

/// Energy of the filtered block, E = integral |x(t)|^2 dt (eq. 11), evaluated by Parseval on
/// the windowed spectrum with the window's power corrected:
///   E = (1/fs) sum_{kept, two-sided k} |X_k|^2 / sum(w^2).
/// White noise of variance s^2 gives on average s^2 TR fraction_kept. Units: unit^2 s.
/// The spread: neighbouring bins of a windowed spectrum are correlated, and summing the
/// correlations over all lags gives, by Parseval on w^2, the factor c_w = N sum(w^4)/sum(w^2)^2
/// (1 rectangular, 35/18 Hann), so relative_std^2 = c_w sum_k (E P_k)^2 / (sum_k P_k)^2 over
/// the kept single-sided bins with P_k = |X_k|^2, where sum (E P_k)^2 is estimated by
/// sum P_k^2 / 2 (P_k of Gaussian noise is exponentially distributed).
EnergyEstimate spectral_energy(const double* x, std::size_t n, double fs, Window window,
                               const BandMask& mask);

/// The filtered block in the time domain: the inverse FFT of the kept bins of the windowed
/// spectrum, divided by sqrt(power gain) so that sum(y^2) / fs equals spectral_energy.
std::vector<double> band_stop(const double* x, std::size_t n, Window window,
                              const BandMask& mask);

/// FFTW's version string, e.g. "fftw-3.3.10-sse2-avx".
std::string fftw_version();

}  // namespace millscope::dsp
