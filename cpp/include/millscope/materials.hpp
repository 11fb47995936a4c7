// Materials and the constants of a pair of them (paper section 3.1 and Tables 2-3; docs/physics.md,
// Pair constants).
//
// A pair of materials i, j has the equivalent quantities
//   1/E* = (1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j,                 E = 2 G (1 + nu)
//   1/G* = 2 (2 - nu_i)(1 + nu_i)/E_i + 2 (2 - nu_j)(1 + nu_j)/E_j
//   beta = ln(e) / sqrt(ln^2(e) + pi^2)                         (eq. 3), e the pair restitution
// and, per contact, the equivalent radius and mass 1/R* = 1/R_i + 1/R_j, 1/m* = 1/m_i + 1/m_j.
// A wall is a material with R_j -> infinity and m_j -> infinity, so R* = R_i and m* = m_i; its
// E* and G* use the wall's material like any other pair.
//
// Everything here is set up once per run; nothing is in the hot loop except reading a
// PairConstants.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace millscope::materials {

inline constexpr double pi = 3.14159265358979323846;

/// An elastic material (SI): paper Table 2.
struct Material {
  double density;        // rho, kg/m^3, > 0
  double shear_modulus;  // G, Pa, > 0
  double poisson;        // nu, in (-1, 0.5)

  /// Young's modulus E = 2 G (1 + nu), Pa.
  double youngs() const { return 2.0 * shear_modulus * (1.0 + poisson); }
};

namespace detail {

inline std::string number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

[[noreturn]] inline void invalid(const std::string& name, double value, const std::string& unit,
                                 const std::string& range) {
  throw std::invalid_argument(name + " = " + number(value) + unit + " is not valid; it must be " +
                              range);
}

}  // namespace detail

/// Throws std::invalid_argument naming `name`'s field, its value and the valid range.
inline void validate(const Material& m, const std::string& name) {
  if (!(std::isfinite(m.density) && m.density > 0.0)) {
    detail::invalid(name + ".density", m.density, " kg/m^3", "finite and > 0");
  }
  if (!(std::isfinite(m.shear_modulus) && m.shear_modulus > 0.0)) {
    detail::invalid(name + ".shear_modulus", m.shear_modulus, " Pa", "finite and > 0");
  }
  if (!(m.poisson > -1.0 && m.poisson < 0.5)) {
    detail::invalid(name + ".poisson", m.poisson, "", "in (-1, 0.5)");
  }
}

/// beta(e) = ln(e) / sqrt(ln^2(e) + pi^2) (eq. 3): -1 < beta <= 0, 0 for e = 1.
inline double beta_of_restitution(double restitution) {
  const double l = std::log(restitution);
  return l / std::sqrt(l * l + pi * pi);
}

/// Throws unless restitution is in (0, 1].
inline void validate_restitution(double restitution, const std::string& name) {
  if (!(restitution > 0.0 && restitution <= 1.0)) {
    detail::invalid(name, restitution, "", "in (0, 1]");
  }
}

/// Throws unless friction is finite and >= 0.
inline void validate_friction(double friction, const std::string& name) {
  if (!(std::isfinite(friction) && friction >= 0.0)) {
    detail::invalid(name, friction, "", "finite and >= 0");
  }
}

/// The constants of a pair of materials: everything the contact law needs that does not depend
/// on the radii or masses of the two bodies.
struct PairConstants {
  double e_star;       // E*, Pa
  double g_star;       // G*, Pa
  double restitution;  // e, in (0, 1]
  double beta;         // eq. 3, in (-1, 0]
  double friction;     // mu (static friction coefficient of eq. 8), >= 0
  // -2 sqrt(5/6) beta >= 0: the viscous coefficient of a spring of stiffness S acting on the
  // equivalent mass m* is gamma = damping_factor sqrt(S m*) (eqs. 2 and 7).
  double damping_factor;
  // sqrt(S_t / S_n) = sqrt(4 G* / E*): S_t (6) and S_n (4) share sqrt(R* d_n), so the
  // tangential damping coefficient is gamma_t = gamma_n x this, one square root fewer.
  double tangential_damping_ratio;
};

/// E* of a pair: 1/E* = (1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j.
inline double effective_youngs(const Material& a, const Material& b) {
  return 1.0 / ((1.0 - a.poisson * a.poisson) / a.youngs() +
                (1.0 - b.poisson * b.poisson) / b.youngs());
}

/// G* of a pair: 1/G* = 2 (2 - nu_i)(1 + nu_i)/E_i + 2 (2 - nu_j)(1 + nu_j)/E_j.
inline double effective_shear(const Material& a, const Material& b) {
  return 1.0 / (2.0 * (2.0 - a.poisson) * (1.0 + a.poisson) / a.youngs() +
                2.0 * (2.0 - b.poisson) * (1.0 + b.poisson) / b.youngs());
}

/// The validated constants of the pair (a, b) with the given restitution and friction.
inline PairConstants make_pair_constants(const Material& a, const Material& b, double restitution,
                                         double friction) {
  validate(a, "material_a");
  validate(b, "material_b");
  validate_restitution(restitution, "restitution");
  validate_friction(friction, "friction");
  PairConstants p{};
  p.e_star = effective_youngs(a, b);
  p.g_star = effective_shear(a, b);
  p.restitution = restitution;
  p.beta = beta_of_restitution(restitution);
  p.friction = friction;
  p.damping_factor = -2.0 * std::sqrt(5.0 / 6.0) * p.beta;
  p.tangential_damping_ratio = std::sqrt(4.0 * p.g_star / p.e_star);
  return p;
}

/// The equivalent of two radii or two masses, x* = 1 / (1/x_i + 1/x_j). A wall passes
/// infinity for x_j (std::numeric_limits<double>::infinity()), which gives x* = x_i exactly.
inline double reduced(double x_i, double x_j) {
  if (std::isinf(x_j)) return x_i;
  if (std::isinf(x_i)) return x_j;
  return x_i * x_j / (x_i + x_j);
}

/// Mass of a sphere, 4/3 pi r^3 rho, kg.
inline double sphere_mass(double density, double radius) {
  return 4.0 / 3.0 * pi * radius * radius * radius * density;
}

/// R* and m* of one contact (precomputable per pair of size fractions).
struct ContactScales {
  double r_star;  // m
  double m_star;  // kg
};

/// R*, m* of two spheres.
inline ContactScales sphere_scales(double r_i, double m_i, double r_j, double m_j) {
  return {reduced(r_i, r_j), reduced(m_i, m_j)};
}

/// R*, m* of a sphere against a wall (R_j, m_j -> infinity).
inline ContactScales wall_scales(double r_i, double m_i) { return {r_i, m_i}; }

/// The n x n symmetric table of PairConstants of a set of materials (wall materials included:
/// the drum is one of the materials). Built once per run.
class PairTable {
 public:
  /// restitution and friction are n x n, row-major, symmetric; entry (i, j) belongs to the pair
  /// of materials i and j. Throws std::invalid_argument naming the first bad entry.
  PairTable(std::vector<Material> materials, const std::vector<double>& restitution,
            const std::vector<double>& friction)
      : n_(materials.size()), materials_(std::move(materials)) {
    if (n_ == 0) throw std::invalid_argument("materials is empty; at least one is needed");
    for (std::size_t i = 0; i < n_; ++i) validate(materials_[i], entry("materials", i));
    check_matrix(restitution, "restitution");
    check_matrix(friction, "friction");
    pairs_.resize(n_ * n_);
    for (std::size_t i = 0; i < n_; ++i) {
      for (std::size_t j = 0; j < n_; ++j) {
        const double e = restitution[i * n_ + j];
        const double mu = friction[i * n_ + j];
        validate_restitution(e, entry("restitution", i, j));
        validate_friction(mu, entry("friction", i, j));
        pairs_[i * n_ + j] = make_pair_constants(materials_[i], materials_[j], e, mu);
      }
    }
  }

  std::size_t size() const { return n_; }
  const Material& material(std::size_t i) const { return materials_.at(i); }

  /// Where the constants of materials i and j lie from &(*this)(0, 0) (kernels that read the
  /// table through an index per contact).
  std::size_t index(std::size_t i, std::size_t j) const { return i * n_ + j; }
  /// The constants of materials i and j (no bounds check: the hot loop reads this).
  const PairConstants& operator()(std::size_t i, std::size_t j) const {
    return pairs_[index(i, j)];
  }
  /// Bounds-checked access.
  const PairConstants& at(std::size_t i, std::size_t j) const {
    if (i >= n_ || j >= n_) {
      throw std::invalid_argument("material index (" + std::to_string(i) + ", " +
                                  std::to_string(j) + ") is not valid; the table has " +
                                  std::to_string(n_) + " materials");
    }
    return pairs_[index(i, j)];
  }

 private:
  static std::string entry(const std::string& name, std::size_t i) {
    return name + "[" + std::to_string(i) + "]";
  }
  static std::string entry(const std::string& name, std::size_t i, std::size_t j) {
    return name + "[" + std::to_string(i) + "][" + std::to_string(j) + "]";
  }

  void check_matrix(const std::vector<double>& m, const std::string& name) const {
    if (m.size() != n_ * n_) {
      throw std::invalid_argument(name + " has " + std::to_string(m.size()) +
                                  " entries; it must be " + std::to_string(n_) + " x " +
                                  std::to_string(n_) + " (one per pair of materials)");
    }
    for (std::size_t i = 0; i < n_; ++i) {
      for (std::size_t j = i + 1; j < n_; ++j) {
        const double a = m[i * n_ + j];
        const double b = m[j * n_ + i];
        if (!(a == b)) {
          throw std::invalid_argument(name + " is not symmetric: " + entry(name, i, j) + " = " +
                                      detail::number(a) + " but " + entry(name, j, i) + " = " +
                                      detail::number(b));
        }
      }
    }
  }

  std::size_t n_;
  std::vector<Material> materials_;
  std::vector<PairConstants> pairs_;
};

}  // namespace millscope::materials
