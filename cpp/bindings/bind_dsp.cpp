// pybind11 glue for millscope::dsp. No physics or signal logic here.
#include <pybind11/stl.h>

#include "millscope/dsp.hpp"
#include "numpy_view.hpp"

namespace millscope::bindings {

void register_dsp(py::module_& m) {
  namespace d = millscope::dsp;
  using py::arg;

  py::class_<d::WindowFactors>(m, "WindowFactors", "Gains of a window of N samples.")
      .def_readonly("coherent_gain", &d::WindowFactors::coherent_gain, "sum(w) / N")
      .def_readonly("power_gain", &d::WindowFactors::power_gain, "sum(w^2) / N")
      .def_readonly("enbw_bins", &d::WindowFactors::enbw_bins,
                    "equivalent noise bandwidth, N sum(w^2) / sum(w)^2, in bins")
      .def_readonly("mainlobe_half_bins", &d::WindowFactors::mainlobe_half_bins,
                    "half-width of the main lobe in bins");

  py::class_<d::Peak>(m, "Peak")
      .def_readonly("frequency_hz", &d::Peak::frequency_hz)
      .def_readonly("amplitude", &d::Peak::amplitude)
      .def_readonly("bin", &d::Peak::bin)
      .def_readonly("noise_amplitude", &d::Peak::noise_amplitude)
      .def_readonly("local_maximum", &d::Peak::local_maximum);

  py::class_<d::BandMask>(m, "BandMask")
      .def_property_readonly("keep",
                             [](const d::BandMask& b) {
                               std::vector<bool> k(b.keep.begin(), b.keep.end());
                               return k;
                             })
      .def_readonly("half_width_hz", &d::BandMask::half_width_hz)
      .def_readonly("widened", &d::BandMask::widened)
      .def_readonly("fraction_kept", &d::BandMask::fraction_kept)
      .def_readonly("centres_hz", &d::BandMask::centres_hz)
      .def_readonly("subtract_mean", &d::BandMask::subtract_mean);

  py::class_<d::EnergyEstimate>(m, "EnergyEstimate")
      .def_readonly("energy", &d::EnergyEstimate::energy)
      .def_readonly("relative_std", &d::EnergyEstimate::relative_std);

  m.def("fftw_version", &d::fftw_version);

  m.def(
      "window",
      [](const std::string& name, std::size_t n) {
        return to_numpy(d::window_samples(d::window_from_name(name), n));
      },
      arg("name"), arg("n"));

  m.def(
      "window_factors",
      [](const std::string& name, std::size_t n) {
        return d::window_factors(d::window_from_name(name), n);
      },
      arg("name"), arg("n"));

  m.def(
      "bin_frequencies",
      [](std::size_t n, double fs) { return to_numpy(d::bin_frequencies(n, fs)); }, arg("n"),
      arg("fs"));

  m.def(
      "spectra",
      [](const InArray& x, double fs, const std::string& window) {
        const double* p = data_1d(x, "x");
        const auto n = static_cast<std::size_t>(x.shape(0));
        const auto w = d::window_from_name(window);
        d::Spectra s;
        {
          py::gil_scoped_release release;
          s = d::spectra(p, n, fs, w);
        }
        return py::make_tuple(to_numpy(std::move(s.amplitude)), to_numpy(std::move(s.power)),
                              to_numpy(std::move(s.psd)));
      },
      arg("x"), arg("fs"), arg("window"),
      "(amplitude, power, psd) of the windowed block, single-sided, from one FFT");

  m.def(
      "find_peak",
      [](const InArray& x, double fs, const std::string& window, double near_hz,
         double search_hz) {
        const double* p = data_1d(x, "x");
        const auto n = static_cast<std::size_t>(x.shape(0));
        const auto w = d::window_from_name(window);
        py::gil_scoped_release release;
        return d::find_peak(p, n, fs, w, near_hz, search_hz);
      },
      arg("x"), arg("fs"), arg("window"), arg("near_hz"), arg("search_hz"));

  m.def(
      "band_mask",
      [](std::size_t n, double fs, const std::string& window, bool remove_mean,
         const std::vector<double>& lines_hz, double bandwidth_hz, double band_lo_hz,
         double band_hi_hz) {
        return d::band_mask(n, fs, d::window_from_name(window), remove_mean, lines_hz,
                            bandwidth_hz, band_lo_hz, band_hi_hz);
      },
      arg("n"), arg("fs"), arg("window"), arg("remove_mean"), arg("lines_hz"),
      arg("bandwidth_hz"), arg("band_lo_hz"), arg("band_hi_hz"));

  m.def(
      "spectral_energy",
      [](const InArray& x, double fs, const std::string& window, const d::BandMask& mask) {
        const double* p = data_1d(x, "x");
        const auto n = static_cast<std::size_t>(x.shape(0));
        const auto w = d::window_from_name(window);
        py::gil_scoped_release release;
        return d::spectral_energy(p, n, fs, w, mask);
      },
      arg("x"), arg("fs"), arg("window"), arg("mask"));

  m.def(
      "band_stop",
      [](const InArray& x, const std::string& window, const d::BandMask& mask) {
        const double* p = data_1d(x, "x");
        const auto n = static_cast<std::size_t>(x.shape(0));
        const auto w = d::window_from_name(window);
        std::vector<double> out;
        {
          py::gil_scoped_release release;
          out = d::band_stop(p, n, w, mask);
        }
        return to_numpy(std::move(out));
      },
      arg("x"), arg("window"), arg("mask"));
}

}  // namespace millscope::bindings
