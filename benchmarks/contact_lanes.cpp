// Probe: what SIMD lanes would give the contact kernel (benchmarks/contact_lanes.sh runs it).
//
// The engine computes one touching pair at a time (cpp/include/millscope/contact.hpp, Eigen
// 3-vectors); callgrind puts a contact at about 345 instructions, and the engine is bound by
// instruction throughput. This probe writes the same Hertz-Mindlin contact with viscous
// damping and Coulomb-limited Mindlin friction (paper eqs. 1-8) in plain scalar form over a
// block of contacts held as arrays, branch-free, so that the compiler can put several contacts
// in the lanes of one instruction. The particles' data are read through the pair's indices
// (i, j), as the engine reads them, with partners near in memory as after the engine's
// space-filling-curve reorder. It is not the engine's code and is not built with the package.
//
//   contact_lanes REPS [OUT]   REPS passes over 22 000 contacts; prints ns per contact;
//                              OUT: the forces, torques and springs, raw doubles, to compare
//                              builds bit for bit
//
// Compiled once without lanes and once with `#pragma omp simd` (-DLANES), with SSE2 (the
// portable baseline) or AVX2. -fno-trapping-math lets the compiler evaluate both sides of a
// select (the sliding branch) in every lane; without it the loop is not vectorised.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace {

struct Particles {  // SI: m, m/s, rad/s, 1/kg
  std::vector<double> x, y, z, vx, vy, vz, wx, wy, wz, r, inv_m;
};

struct Contacts {  // one touching pair per entry
  std::vector<std::uint32_t> i, j;
  std::vector<double> dx, dy, dz;        // x_i - x_j, m
  std::vector<double> sx, sy, sz;        // tangential spring d_t, m (updated)
  std::vector<double> fx, fy, fz;        // force on i, N
  std::vector<double> tx, ty, tz;        // torque on i, N m
};

// Steel on steel (G 81 GPa, nu 0.3, e 0.5, mu 0.15): E* = E / (2 (1 - nu^2)) in Pa,
// G* = G / (2 (2 - nu)) in Pa, the damping factor -2 sqrt(5/6) beta with beta of eq. 3.
constexpr double e_star = 115.71e9, g_star = 23.82e9, damping_factor = 0.3933, mu = 0.15;

double kernel(const Particles& p, Contacts& c, double dt) {
  const double tangential_ratio = std::sqrt(4.0 * g_star / e_star);
  const std::size_t n = c.i.size();
#ifdef LANES
#pragma omp simd
#endif
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = c.i[k], j = c.j[k];
    const double ri = p.r[i], rj = p.r[j], r_sum = ri + rj;
    const double dist = std::sqrt(c.dx[k] * c.dx[k] + c.dy[k] * c.dy[k] + c.dz[k] * c.dz[k]);
    const double inv_dist = 1.0 / dist;
    const double nx = c.dx[k] * inv_dist, ny = c.dy[k] * inv_dist, nz = c.dz[k] * inv_dist;
    const double d_n = r_sum - dist;
    const double r_star = ri * rj / r_sum, m_star = 1.0 / (p.inv_m[i] + p.inv_m[j]);
    // contact-point velocity of i relative to j: v_i - v_j + w_i x (-r_i n) - w_j x (r_j n)
    const double ax = -ri * nx, ay = -ri * ny, az = -ri * nz;
    const double bx = rj * nx, by = rj * ny, bz = rj * nz;
    const double vrx = p.vx[i] - p.vx[j] + (p.wy[i] * az - p.wz[i] * ay) - (p.wy[j] * bz - p.wz[j] * by);
    const double vry = p.vy[i] - p.vy[j] + (p.wz[i] * ax - p.wx[i] * az) - (p.wz[j] * bx - p.wx[j] * bz);
    const double vrz = p.vz[i] - p.vz[j] + (p.wx[i] * ay - p.wy[i] * ax) - (p.wx[j] * by - p.wy[j] * bx);
    const double v_n = vrx * nx + vry * ny + vrz * nz;
    const double vtx = vrx - v_n * nx, vty = vry - v_n * ny, vtz = vrz - v_n * nz;
    const double sqrt_rd = std::sqrt(r_star * d_n);
    const double s_n = 2.0 * e_star * sqrt_rd;                       // (4)
    const double gamma_n = damping_factor * std::sqrt(s_n * m_star);  // (2)
    const double f_n = (2.0 / 3.0) * s_n * d_n - gamma_n * v_n;       // (1) + (2)
    const double s_t = 8.0 * g_star * sqrt_rd;                        // (6)
    // spring turned into the current tangent plane, its length kept, then advanced
    double sx = c.sx[k], sy = c.sy[k], sz = c.sz[k];
    const double before2 = sx * sx + sy * sy + sz * sz;
    const double along = sx * nx + sy * ny + sz * nz;
    sx -= along * nx, sy -= along * ny, sz -= along * nz;
    const double after2 = sx * sx + sy * sy + sz * sz;
    const double keep = after2 > 0.0 ? std::sqrt(before2 / after2) : 0.0;
    sx = sx * keep + vtx * dt, sy = sy * keep + vty * dt, sz = sz * keep + vtz * dt;
    const double gamma_t = gamma_n * tangential_ratio;  // (7)
    double ftx = -s_t * sx - gamma_t * vtx, fty = -s_t * sy - gamma_t * vty,
           ftz = -s_t * sz - gamma_t * vtz;  // (5) + (7)
    const double limit = mu * std::fabs(f_n);  // (8)
    const double f2 = ftx * ftx + fty * fty + ftz * ftz;
    const bool sliding = f2 > limit * limit;
    const double scale = sliding ? limit / std::sqrt(f2) : 1.0;
    ftx *= scale, fty *= scale, ftz *= scale;
    const double back = -1.0 / s_t;
    c.sx[k] = sliding ? ftx * back : sx;
    c.sy[k] = sliding ? fty * back : sy;
    c.sz[k] = sliding ? ftz * back : sz;
    c.fx[k] = f_n * nx + ftx, c.fy[k] = f_n * ny + fty, c.fz[k] = f_n * nz + ftz;
    c.tx[k] = -ri * (ny * ftz - nz * fty);  // (-r_i n) x F_t
    c.ty[k] = -ri * (nz * ftx - nx * ftz);
    c.tz[k] = -ri * (nx * fty - ny * ftx);
  }
  double sum = 0.0;  // a checksum, so that the work is kept
  for (std::size_t k = 0; k < n; ++k) sum += c.fx[k];
  return sum;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::atoi(argv[1]) < 1) {
    std::fprintf(stderr, "usage: %s REPS [OUT]  (REPS >= 1)\n", argv[0]);
    return 2;
  }
  const int reps = std::atoi(argv[1]);
  const std::uint32_t n = 20000, n_contacts = 22000;
  const double dt = 2.64e-6;  // s, 0.2 x the ball Rayleigh time
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Particles p;
  for (auto* v : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz, &p.wx, &p.wy, &p.wz, &p.r, &p.inv_m})
    v->resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    p.vx[i] = u(rng), p.vy[i] = u(rng), p.vz[i] = u(rng);
    p.wx[i] = 10 * u(rng), p.wy[i] = 10 * u(rng), p.wz[i] = 10 * u(rng);
    p.r[i] = 0.0125, p.inv_m[i] = 1.0 / 0.0643;  // 25 mm steel ball
  }
  Contacts c;
  for (auto* v : {&c.i, &c.j}) v->resize(n_contacts);
  for (auto* v : {&c.dx, &c.dy, &c.dz, &c.sx, &c.sy, &c.sz, &c.fx, &c.fy, &c.fz, &c.tx, &c.ty,
                  &c.tz})
    v->resize(n_contacts);
  for (std::uint32_t k = 0; k < n_contacts; ++k) {
    c.i[k] = (k * 6 / 7) % n;              // rows in order, about 1.1 contacts each
    c.j[k] = (c.i[k] + 1 + k % 9) % n;     // partners a few places on, as after a reorder
    const double a = u(rng), b = u(rng), d = u(rng);
    const double to_dist = (0.025 - 1e-4 * (1.0 + u(rng))) / std::sqrt(a * a + b * b + d * d);
    c.dx[k] = a * to_dist, c.dy[k] = b * to_dist, c.dz[k] = d * to_dist;  // overlap 0-0.2 mm
    c.sx[k] = 1e-6 * u(rng), c.sy[k] = 1e-6 * u(rng), c.sz[k] = 1e-6 * u(rng);
  }
  double sink = kernel(p, c, dt);  // warm-up
  const auto t0 = std::chrono::steady_clock::now();
  for (int rep = 0; rep < reps; ++rep) sink += kernel(p, c, dt);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("ns_per_contact=%.2f (checksum %.17g)\n", s / (double(reps) * n_contacts) * 1e9,
              sink);
  if (argc > 2) {
    std::FILE* f = std::fopen(argv[2], "wb");
    if (f == nullptr) {
      std::fprintf(stderr, "cannot write %s\n", argv[2]);
      return 1;
    }
    for (auto* v : {&c.fx, &c.fy, &c.fz, &c.tx, &c.ty, &c.tz, &c.sx, &c.sy, &c.sz})
      std::fwrite(v->data(), sizeof(double), v->size(), f);
    std::fclose(f);
  }
  return 0;
}
