// The engine's set-up, state access, observables and checkpoints (engine.hpp), and the list
// upkeep the step kernels call (Access). The step loop itself is in src/step/run.hpp.
#include "millscope/engine.hpp"

#include "engine_access.hpp"
#include "lane_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "millscope/contact.hpp"
#include "millscope/timestep.hpp"

namespace millscope::engine {

namespace {

// What a thread's share of the work costs, for splitting the work among the threads in
// contiguous blocks (Access::split_rows, Access::split_particles). The weights fit the time
// each thread spends between list builds (2 threads, the paper-scale balls and ceramic4
// scenes): the ratio of the two threads' times against the ratio of their weighted counts.
// A listed pair that touches costs the pair pass about 6 times one that does not (its law in
// lanes and its sums, besides the distance test); ceramic4, whose blocks touch unevenly, fits
// best with 6 to 8, and the balls, whose halves touch alike, fit any weight from 1 to 8.
constexpr double touching_pair_cost = 6.0;  // in listed pairs that do not touch
// A particle in contact with the drum costs the particle pass and the kick and drift about 3
// times one that is not (its wall law and torque). A finer model (by the distance to the shell)
// moves the cut by about 1 % of the cost, too little to be worth its complexity.
constexpr double drum_contact_cost = 3.0;  // in particles not in contact with it
// The gap within which a listed pair counts as near (src/step/near_pairs.hpp) at first, as a
// fraction of the skin; the step loop then adapts it to the scene (run.hpp).
constexpr double near_gap_fraction = 0.25;

/// Boundaries 0 = split[0] <= split[1] <= ... <= split[team] = n cutting items 0..n-1 into team
/// contiguous blocks of about equal cost (cost[i] >= 0): block t is [split[t], split[t+1]),
/// split[t] the first item before which the cost reaches t / team of the total.
void split_by_cost(const std::vector<double>& cost, std::size_t team,
                   std::vector<std::size_t>& split) {
  const std::size_t n = cost.size();
  const double total = std::accumulate(cost.begin(), cost.end(), 0.0);
  split.assign(team + 1, n);
  split[0] = 0;
  std::size_t i = 0;
  double before = 0.0;  // cost of the items before i
  for (std::size_t t = 1; t < team; ++t) {
    const double goal = total * static_cast<double>(t) / static_cast<double>(team);
    while (i < n && before < goal) before += cost[i++];
    split[t] = i;
  }
}

/// Whether a sphere (centre x, y, z and radius r, m) comes within `margin` (m) of the drum's
/// shell or, with end walls, of an end wall.
bool near_shell_or_ends(const drum::Geometry& g, double x, double y, double z, double r,
                        double margin) {
  const bool shell = std::hypot(x, y) + r + margin > g.radius;
  return shell || (g.end_walls && (z - r < margin || z + r + margin > g.length));
}

[[noreturn]] void invalid(const std::string& name, double value, const std::string& range) {
  std::ostringstream msg;
  msg << name << " = " << value << " is not valid; it must be " << range;
  throw std::invalid_argument(msg.str());
}

/// Materials in use: the drum's and every particle's.
std::set<int> used_materials(const Config& c) {
  std::set<int> used(c.material.begin(), c.material.end());
  used.insert(c.drum_material);
  return used;
}

void validate(const Config& c) {
  const auto n_mat = static_cast<int>(c.materials.size());
  if (n_mat == 0) throw std::invalid_argument("materials is empty; at least one is needed");
  if (n_mat > 256) invalid("the number of materials", n_mat, "<= 256");
  if (c.drum_material < 0 || c.drum_material >= n_mat)
    invalid("drum_material", c.drum_material, "an index in [0, " + std::to_string(n_mat) + ")");
  c.geometry.validate();
  if (c.radius.empty()) throw std::invalid_argument("the charge is empty; at least one particle is needed");
  if (c.radius.size() != c.material.size()) {
    throw std::invalid_argument("radius has " + std::to_string(c.radius.size()) +
                                " entries but material has " + std::to_string(c.material.size()) +
                                "; they must match (one per particle)");
  }
  for (std::size_t i = 0; i < c.radius.size(); ++i) {
    const std::string at = "[" + std::to_string(i) + "]";
    if (!(c.radius[i] > 0.0) || !std::isfinite(c.radius[i])) invalid("radius" + at, c.radius[i], "finite and > 0 m");
    if (c.material[i] < 0 || c.material[i] >= n_mat)
      invalid("material" + at, c.material[i], "an index in [0, " + std::to_string(n_mat) + ")");
  }
  if (!(c.gravity >= 0.0) || !std::isfinite(c.gravity)) invalid("gravity", c.gravity, "finite and >= 0 m/s^2");
  if (!(c.skin >= 0.0) || !std::isfinite(c.skin)) invalid("skin", c.skin, "finite and >= 0 m (0: default)");
  if (c.threads < 1) invalid("threads", c.threads, ">= 1");
  if (!(c.max_speed > 0.0)) invalid("max_speed", c.max_speed, "> 0 m/s (infinity: no bound)");
  if (!(c.max_overlap > 0.0 && c.max_overlap <= 1.0))
    invalid("max_overlap", c.max_overlap, "in (0, 1] (a fraction of the smaller radius)");
  // The time step against the smallest Rayleigh time of the charge (docs/physics.md, Time step).
  double t_min = HUGE_VAL;
  for (std::size_t i = 0; i < c.radius.size(); ++i) {
    const auto& mat = c.materials[static_cast<std::size_t>(c.material[i])];
    t_min = std::min(t_min, timestep::rayleigh_time(c.radius[i], mat.density, mat.shear_modulus,
                                                    mat.poisson));
  }
  timestep::require_stable_dt(c.dt, t_min);
}

Variant choose_variant(const Config& c, const materials::PairTable& table) {
  const std::set<int> used = used_materials(c);
  bool friction = false, damping = false;
  for (int a : used) {
    for (int b : used) {
      const auto& p = table.at(static_cast<std::size_t>(a), static_cast<std::size_t>(b));
      friction = friction || p.friction > 0.0;
      damping = damping || p.restitution < 1.0;
    }
  }
  Variant v;
  // The engine's clamped kernels carry friction (mu = 0 gives no tangential force): there are
  // no frictionless clamped ones.
  v.law = contact::choose_law(friction || c.clamp_normal, damping, c.clamp_normal);
  v.one_material = used.size() == 1;
  v.lifters = c.geometry.lifters > 0;
  v.end_walls = c.geometry.end_walls;
  v.track_energy = c.track_energy && v.law != Variant::Law::elastic;
  return v;
}

StepKernel kernel_of(const Variant& v) {
  switch (v.law) {
    case Variant::Law::hertz_mindlin:
      return kernels::hertz_mindlin(v.one_material, v.lifters, v.end_walls, v.track_energy);
    case Variant::Law::frictionless:
      return kernels::frictionless(v.one_material, v.lifters, v.end_walls, v.track_energy);
    case Variant::Law::elastic:
      return kernels::elastic(v.one_material, v.lifters, v.end_walls, v.track_energy);
    case Variant::Law::clamped:
      return kernels::clamped(v.one_material, v.lifters, v.end_walls, v.track_energy);
    case Variant::Law::frictionless_clamped:
      break;  // never chosen (choose_variant)
  }
  throw std::logic_error("the engine has no step kernels for this contact law");
}

bool has_friction(const Variant& v) { return contact::has_friction(v.law); }

double default_skin(const std::vector<double>& radius) {
  // 0.4 r_min: 5 mm for the pilot mill's 12.5 mm balls, as the LIGGGHTS yardstick uses.
  return 0.4 * *std::min_element(radius.begin(), radius.end());
}

}  // namespace

std::string Variant::describe() const {
  static const char* laws[] = {"hertz-mindlin", "hertz-mindlin without friction",
                               "hertz elastic without friction", "hertz-mindlin, clamped",
                               "hertz-mindlin without friction, clamped"};
  std::string s = laws[static_cast<int>(law)];
  s += one_material ? ", one material" : ", pair table";
  s += lifters ? ", lifters" : ", no lifters";
  s += end_walls ? ", end walls" : ", periodic ends";
  if (!track_energy && law != Law::elastic) s += ", dissipation not booked";
  return s;
}

const SimdPath& Engine::simd() const { return lanes_->path; }

void Engine::set_running_threads(int n) {
  if (n < 1 || n > threads_)
    invalid("running_threads", n, "in [1, threads = " + std::to_string(threads_) + "]");
  running_threads_ = n;
}

bool Engine::wide_pair_search() const {
  return lanes_->path.pair_lanes > 1 && variant_.law == Variant::Law::hertz_mindlin &&
         !variant_.track_energy;
}

namespace {

/// Bytes of the CPU's last-level cache, as Linux describes CPU 0's caches
/// (/sys/devices/system/cpu/cpu0/cache/index*/: level, type, size as "32768K"); 32 MiB where it
/// does not. (sysconf(_SC_LEVEL3_CACHE_SIZE) is not asked: on an AMD EPYC virtual machine
/// with a 32 MiB third level, glibc gave 320 MiB.)
double last_level_cache_bytes() {
  int best_level = 0;
  double best_bytes = 32.0 * 1024 * 1024;
  for (int index = 0; index < 16; ++index) {
    const std::string dir =
        "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(index) + "/";
    std::ifstream level_file(dir + "level"), type_file(dir + "type"), size_file(dir + "size");
    int level = 0;
    std::string type, size;
    if (!(level_file >> level) || !(type_file >> type) || !(size_file >> size)) break;
    if (type == "Instruction" || level <= best_level || size.empty()) continue;
    double bytes = std::strtod(size.c_str(), nullptr);
    if (size.back() == 'K') bytes *= 1024;
    if (size.back() == 'M') bytes *= 1024 * 1024;
    if (bytes > 0) best_level = level, best_bytes = bytes;
  }
  return best_bytes;
}

}  // namespace

bool Engine::prefetch_partners() const {
  if (!wide_pair_search()) return false;
  if (config_.prefetch_partners.has_value()) return *config_.prefetch_partners;
  return bytes_per_particle() * static_cast<double>(n_) > cache_bytes_;
}

Engine::Engine(Config config)
    : config_((validate(config), std::move(config))),
      n_(config_.radius.size()),
      cache_bytes_(last_level_cache_bytes()),
      dt_(config_.dt),
      threads_(config_.threads),
      running_threads_(config_.threads),
      lanes_(&lane_kernels(config_.simd)),
      pairs_(config_.materials, config_.restitution, config_.friction),
      list_(config_.skin > 0.0 ? config_.skin : default_skin(config_.radius),
            0, config_.geometry.end_walls ? 0.0 : config_.geometry.length) {
  variant_ = choose_variant(config_, pairs_);
  kernel_ = kernel_of(variant_);
  const bool friction = has_friction(variant_);
  list_ = neighbors::VerletList(list_.skin(), contact::history_size(variant_.law),
                                config_.geometry.end_walls ? 0.0 : config_.geometry.length);
  near_gap_ = near_gap_fraction * list_.skin();

  for (auto* v : {&x_, &y_, &z_, &vx_, &vy_, &vz_, &wx_, &wy_, &wz_, &fx_, &fy_, &fz_, &tx_, &ty_,
                  &tz_})
    v->assign(n_, 0.0);
  for (auto* v : {&x_ref_, &y_ref_, &z_ref_}) v->assign(n_, 0.0f);
  order_.resize(n_);
  std::iota(order_.begin(), order_.end(), 0u);
  set_particle_constants();
  wall_block_.assign(friction ? n_ : 0, -1);  // blocks are handed out by refresh_walls
  wall_held_.assign(friction ? n_ : 0, 0);
  // Forces and torques (6), and when the step books the dissipated energy, the dissipating
  // force and torque (6 more) per particle (engine.hpp, buffer_width). The buffers are sized by
  // split_rows.
  buffer_width_ = buffer_width(variant_.track_energy);
  dissipative_.assign(variant_.track_energy ? 6 * n_ : 0, 0.0);
  buffers_.assign(static_cast<std::size_t>(threads_), std::vector<double>());
  row_split_.assign(static_cast<std::size_t>(threads_) + 1, 0);
  particle_split_.assign(static_cast<std::size_t>(threads_) + 1, 0);
  buffer_end_.assign(static_cast<std::size_t>(threads_), 0);
}

void Engine::set_particle_constants() {
  r_.resize(n_);
  mat_.resize(n_);
  m_.resize(n_);
  inv_m_.resize(n_);
  inv_i_.resize(n_);
  for (std::size_t k = 0; k < n_; ++k) {
    r_[k] = config_.radius[order_[k]];
    mat_[k] = static_cast<std::uint8_t>(config_.material[order_[k]]);
    const auto& mat = config_.materials[static_cast<std::size_t>(mat_[k])];
    m_[k] = materials::sphere_mass(mat.density, r_[k]);
    inv_m_[k] = 1.0 / m_[k];
    inv_i_[k] = 1.0 / (0.4 * m_[k] * r_[k] * r_[k]);  // solid sphere, I = 2/5 m r^2
  }
}

double Engine::bytes_per_particle() const {
  auto bytes = [](const auto& v) { return static_cast<double>(v.capacity() * sizeof(v[0])); };
  double total = 0.0;
  for (const auto* v : {&x_, &y_, &z_, &vx_, &vy_, &vz_, &wx_, &wy_, &wz_, &fx_, &fy_, &fz_, &tx_,
                        &ty_, &tz_, &r_, &m_, &inv_m_, &inv_i_, &wall_history_, &dissipative_})
    total += bytes(*v);
  total += bytes(x_ref_) + bytes(y_ref_) + bytes(z_ref_);
  total += bytes(mat_) + bytes(wall_block_) + bytes(wall_lifter_) + bytes(wall_held_) +
           bytes(order_) + bytes(lifter_reach_);
  for (const auto& b : buffers_) total += bytes(b);
  total += static_cast<double>(list_.bytes()) + bytes(list_moved_) + bytes(touch_dist2_) +
           bytes(row_split_) + bytes(particle_split_) + bytes(buffer_end_);
  return total / static_cast<double>(n_);
}

void Engine::start_rotation(double omega) {
  if (!std::isfinite(omega)) invalid("omega", omega, "finite (rad/s)");
  omega_ = omega;
  rotation_start_ = step_;
  last_sample_offset_ = -1;
  sampling_ = SamplingState{};
}

namespace {
/// Reads n x 3 values into three arrays; slot k takes row order[k] (or row k without order).
template <class T>
void copy_in(const double* xyz, std::size_t n, std::vector<T>& a, std::vector<T>& b,
             std::vector<T>& c, const char* what, const std::uint32_t* order = nullptr) {
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = order != nullptr ? order[k] : k;
    if (!std::isfinite(xyz[3 * i]) || !std::isfinite(xyz[3 * i + 1]) ||
        !std::isfinite(xyz[3 * i + 2])) {
      throw std::invalid_argument(std::string(what) + "[" + std::to_string(i) +
                                  "] is not finite; every value must be");
    }
    a[k] = static_cast<T>(xyz[3 * i]);
    b[k] = static_cast<T>(xyz[3 * i + 1]);
    c[k] = static_cast<T>(xyz[3 * i + 2]);
  }
}
/// Writes three arrays as n x 3 values; slot k goes to row order[k] (or row k without order).
template <class T>
std::vector<double> copy_out(const std::vector<T>& a, const std::vector<T>& b,
                             const std::vector<T>& c, const std::uint32_t* order = nullptr) {
  std::vector<double> out(3 * a.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    const std::size_t i = order != nullptr ? order[k] : k;
    out[3 * i] = a[k];
    out[3 * i + 1] = b[k];
    out[3 * i + 2] = c[k];
  }
  return out;
}
/// The values of a per-slot array in the caller's order.
std::vector<double> in_caller_order(const std::vector<double>& a,
                                    const std::vector<std::uint32_t>& order) {
  std::vector<double> out(a.size());
  for (std::size_t k = 0; k < a.size(); ++k) out[order[k]] = a[k];
  return out;
}
/// a[k] = old a[from[k]] for blocks of `block` values per particle. In place: the step kernel
/// holds pointers into the arrays across a rebuild.
template <class T>
void permute(std::vector<T>& a, const std::vector<std::uint32_t>& from, std::size_t block,
             std::vector<T>& scratch) {
  if (a.empty()) return;
  scratch.resize(a.size());
  for (std::size_t k = 0; k < from.size(); ++k)
    std::copy_n(a.begin() + static_cast<std::ptrdiff_t>(from[k] * block), block,
                scratch.begin() + static_cast<std::ptrdiff_t>(k * block));
  std::copy(scratch.begin(), scratch.end(), a.begin());
}
}  // namespace

void Engine::set_positions(const double* xyz) {
  copy_in(xyz, n_, x_, y_, z_, "positions", order_.data());
  // A new configuration: no contact history survives, the list is built afresh.
  list_ = neighbors::VerletList(list_.skin(), list_.history_size(),
                                config_.geometry.end_walls ? 0.0 : config_.geometry.length);
  wall_history_.clear();
  wall_lifter_.clear();
  std::fill(wall_block_.begin(), wall_block_.end(), -1);
  std::fill(wall_held_.begin(), wall_held_.end(), std::uint8_t{0});
  forces_valid_ = false;
}
void Engine::set_velocities(const double* v) {
  copy_in(v, n_, vx_, vy_, vz_, "velocities", order_.data());
  forces_valid_ = false;
}
void Engine::set_spins(const double* w) {
  copy_in(w, n_, wx_, wy_, wz_, "spins", order_.data());
  forces_valid_ = false;
}
std::vector<double> Engine::positions() const { return copy_out(x_, y_, z_, order_.data()); }
std::vector<double> Engine::velocities() const { return copy_out(vx_, vy_, vz_, order_.data()); }
std::vector<double> Engine::spins() const { return copy_out(wx_, wy_, wz_, order_.data()); }
std::vector<double> Engine::radius() const { return in_caller_order(r_, order_); }
std::vector<double> Engine::mass() const { return in_caller_order(m_, order_); }

void Engine::advance(long steps) {
  if (steps < 0) invalid("steps", static_cast<double>(steps), ">= 0");
  kernel_(*this, steps, nullptr);
}

namespace {

/// Takes torque samples at the steps nearest k sample_dt after the start of rotation, in both
/// modes at once: the torque of that step and the mean over the steps of its interval. A row
/// holds the time, the sample in the call's mode, then the sample in the other mode, so one run
/// gives the record of each (the paper's instantaneous samples and the anti-aliased means).
class Sampler final : public StepObserver {
 public:
  Sampler(double dt, long rotation_start, const SamplingState& state)
      : ratio_(state.sample_dt / dt), rotation_start_(rotation_start), state_(state) {}

  long target(long k) const { return std::llround(static_cast<double>(k) * ratio_); }
  long last_offset() const { return target(state_.next + state_.left - 1); }
  const SamplingState& state() const { return state_; }

  void after_step(long step, const Torque& t) override {
    auto& s = state_;
    s.step = step;
    if (s.left <= 0) return;
    const long offset = step - rotation_start_;
    // The mean of sample k covers exactly the steps ending in (t_(k-1), t_k]; a call that
    // starts before that interval runs its first steps without counting them.
    if (offset > target(s.next - 1)) {
      s.sum.total += t.total;
      s.sum.shell += t.shell;
      s.sum.lifters += t.lifters;
      s.sum.ends += t.ends;
      ++s.terms;
    }
    if (offset != target(s.next)) return;
    const double w = 1.0 / static_cast<double>(s.terms);
    const Torque mean{s.sum.total * w, s.sum.shell * w, s.sum.lifters * w, s.sum.ends * w};
    s.sum = Torque{};
    s.terms = 0;
    // `t` is the torque of the step nearest t_k, the instantaneous sample.
    if (s.mean)
      record(mean, t);
    else
      record(t, mean);
    last_sampled = offset;
  }

  std::vector<double> out;
  long last_sampled = -1;

 private:
  void record(const Torque& t, const Torque& other) {
    out.insert(out.end(), {static_cast<double>(state_.next) * state_.sample_dt, t.total, t.shell,
                           t.lifters, t.ends, other.total, other.shell, other.lifters,
                           other.ends});
    ++state_.next;
    --state_.left;
  }

  double ratio_;
  long rotation_start_;
  SamplingState state_;
};

}  // namespace

std::vector<double> Engine::advance_sampled(double sample_dt, bool mean, long count,
                                            long max_steps, bool resume) {
  if (rotation_start_ < 0)
    throw std::logic_error("the drum has not started rotating; call start_rotation first");
  if (!(sample_dt >= dt_) || !std::isfinite(sample_dt))
    invalid("sample_dt", sample_dt, ">= the time step dt = " + std::to_string(dt_) + " s");
  if (count < 1) invalid("count", static_cast<double>(count), ">= 1");
  if (max_steps < 1) invalid("max_steps", static_cast<double>(max_steps), ">= 1");
  const long offset = step_ - rotation_start_;
  SamplingState state;
  if (resume) {
    if (sampling_.step != step_ || sampling_.sample_dt != sample_dt || sampling_.mean != mean)
      throw std::logic_error("advance_sampled(resume=True) must follow a call with the same "
                             "sample_dt and mode, with no step in between");
    state = sampling_;
  } else {
    // The first sample is the first whose interval (t_(k-1), t_k] starts now or later, and
    // after the last sample taken: a run of n samples from a sample time advances exactly
    // n sample_dt.
    state.sample_dt = sample_dt;
    state.mean = mean;
    state.step = step_;
    const Sampler probe(dt_, rotation_start_, state);
    long first = std::max(
        1L, static_cast<long>(std::floor(static_cast<double>(offset) * dt_ / sample_dt)) - 1);
    while (probe.target(first - 1) < offset || probe.target(first) <= last_sample_offset_) ++first;
    state.next = first;
  }
  state.left = count;
  Sampler sampler(dt_, rotation_start_, state);
  const long steps = std::min(sampler.last_offset() - offset, max_steps);
  kernel_(*this, steps, &sampler);
  sampling_ = sampler.state();
  sampling_.step = step_;
  if (sampler.last_sampled >= 0) last_sample_offset_ = sampler.last_sampled;
  return std::move(sampler.out);
}

double Engine::kinetic_energy() const {
  double e = 0.0;
  for (std::size_t i = 0; i < n_; ++i) {
    const double v2 = vx_[i] * vx_[i] + vy_[i] * vy_[i] + vz_[i] * vz_[i];
    const double w2 = wx_[i] * wx_[i] + wy_[i] * wy_[i] + wz_[i] * wz_[i];
    e += 0.5 * m_[i] * v2 + 0.5 * (0.4 * m_[i] * r_[i] * r_[i]) * w2;
  }
  return e;
}

double Engine::potential_energy() const {
  double e = 0.0;
  for (std::size_t i = 0; i < n_; ++i) e += m_[i] * config_.gravity * y_[i];
  return e;
}

namespace {
/// Visits every touching contact: f(pair constants, overlap, R*, smaller radius, history or null).
template <class F>
void for_each_contact(const Engine& e, const materials::PairTable& table, const Config& c,
                      const std::vector<double>& r, const std::vector<std::uint8_t>& mat,
                      const std::vector<double>& x, const std::vector<double>& y,
                      const std::vector<double>& z, const neighbors::VerletList& list,
                      const std::vector<std::int32_t>& wall_block,
                      const std::vector<double>& wall_history,
                      const std::vector<std::int32_t>& wall_lifter, F&& f) {
  const std::size_t hs = list.history_size();
  const double period = c.geometry.length;
  const bool listed = list.start().size() == e.size() + 1;  // not before the first build
  drum::LifterAngles at;
  at.update(c.geometry, e.drum_angle());
  for (std::size_t i = 0; i < e.size(); ++i) {
    for (std::uint32_t s = listed ? list.start()[i] : 0; listed && s < list.start()[i + 1]; ++s) {
      const std::size_t j = list.partner()[s];
      double dz = z[i] - z[j];
      if (!c.geometry.end_walls) dz -= period * std::nearbyint(dz / period);
      const double dist = std::sqrt((x[i] - x[j]) * (x[i] - x[j]) + (y[i] - y[j]) * (y[i] - y[j]) + dz * dz);
      const double d_n = r[i] + r[j] - dist;
      if (d_n <= 0.0) continue;
      const auto& p = table(static_cast<std::size_t>(mat[i]), static_cast<std::size_t>(mat[j]));
      f(p, d_n, r[i] * r[j] / (r[i] + r[j]), std::min(r[i], r[j]),
        hs > 0 ? list.history().data() + s * hs : nullptr);
    }
    const auto found = drum::find_contacts(c.geometry, at, contact::Vec3(x[i], y[i], z[i]), r[i]);
    for (int k = 0; k < found.count; ++k) {
      const auto& wc = found.items[static_cast<std::size_t>(k)];
      const double* hist = nullptr;
      if (!wall_block.empty() && wall_block[i] >= 0) {
        const auto block = static_cast<std::size_t>(wall_block[i]);
        std::size_t slot = static_cast<std::size_t>(wc.part);
        if (wc.part == drum::Part::lifter) slot = wall_lifter[2 * block] == wc.index ? 3 : 4;
        hist = wall_history.data() + (block * wall_slots + slot) * hs;
      }
      const auto& p = table(static_cast<std::size_t>(mat[i]), static_cast<std::size_t>(c.drum_material));
      f(p, wc.overlap, r[i], r[i], hist);
    }
  }
}
}  // namespace

double Engine::elastic_energy() const {
  double u = 0.0;
  const bool friction = has_friction(variant_);
  for_each_contact(*this, pairs_, config_, r_, mat_, x_, y_, z_, list_, wall_block_, wall_history_,
                   wall_lifter_,
                   [&](const materials::PairConstants& p, double d_n, double r_star, double,
                       const double* hist) {
                     const double sqrt_rd = std::sqrt(r_star * d_n);
                     u += contact::HertzElastic::energy(p, sqrt_rd, d_n);
                     if (friction && hist != nullptr) u += contact::MindlinFriction::energy(p, sqrt_rd, hist);
                   });
  return u;
}

double Engine::max_overlap_ratio() const {
  double worst = 0.0;
  for_each_contact(*this, pairs_, config_, r_, mat_, x_, y_, z_, list_, wall_block_, wall_history_,
                   wall_lifter_,
                   [&](const materials::PairConstants&, double d_n, double, double r_small,
                       const double*) { worst = std::max(worst, d_n / r_small); });
  return worst;
}

Engine::Snapshot Engine::snapshot() const {
  Snapshot s;
  s.order = order_;
  s.x = copy_out(x_, y_, z_);
  s.v = copy_out(vx_, vy_, vz_);
  s.w = copy_out(wx_, wy_, wz_);
  s.f = copy_out(fx_, fy_, fz_);
  s.t = copy_out(tx_, ty_, tz_);
  s.x_ref = copy_out(x_ref_, y_ref_, z_ref_);
  // Wall history per particle (slot order), as if every particle had a block.
  const std::size_t width = wall_slots * history_size();  // wall history per particle
  s.wall_history.assign(wall_block_.empty() ? 0 : n_ * width, 0.0);
  s.wall_lifter.assign(2 * n_, -1);
  for (std::size_t i = 0; i < wall_block_.size(); ++i) {
    if (wall_block_[i] < 0) continue;
    const auto b = static_cast<std::size_t>(wall_block_[i]);
    std::copy_n(wall_history_.begin() + static_cast<std::ptrdiff_t>(b * width), width,
                s.wall_history.begin() + static_cast<std::ptrdiff_t>(i * width));
    std::copy_n(wall_lifter_.begin() + static_cast<std::ptrdiff_t>(2 * b), 2,
                s.wall_lifter.begin() + static_cast<std::ptrdiff_t>(2 * i));
  }
  s.list_start = list_.start();
  s.list_partner = list_.partner();
  s.list_history = list_.history();
  s.step = step_;
  s.rotation_start = rotation_start_;
  s.last_sample_offset = last_sample_offset_;
  s.list_builds = list_.builds();
  s.theta = theta_;
  s.omega = omega_;
  s.forces_valid = forces_valid_;
  s.torque = torque_;
  s.ledger = ledger_;
  return s;
}

void Engine::restore(const Snapshot& s) {
  const std::size_t n3 = 3 * n_;
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("the snapshot does not fit this engine: " + what);
  };
  for (const auto* a : {&s.x, &s.v, &s.w, &s.f, &s.t, &s.x_ref})
    require(a->size() == n3, "a state array has " + std::to_string(a->size()) + " values, not " + std::to_string(n3));
  require(s.wall_history.size() == (wall_block_.empty() ? 0 : n_ * wall_slots * history_size()),
          "wall history size");
  require(s.wall_lifter.size() == 2 * n_, "wall lifter slots size");
  require(s.step >= 0, "step < 0");
  require(s.order.size() == n_, "order has " + std::to_string(s.order.size()) + " entries, not " +
                                    std::to_string(n_));
  {
    std::vector<bool> seen(n_, false);
    for (const std::uint32_t k : s.order) {
      require(k < n_ && !seen[k], "order is not a permutation of the particles");
      seen[k] = true;
    }
  }
  list_.restore(n_, s.list_start, s.list_partner, s.list_history, s.list_builds);
  order_ = s.order;
  set_particle_constants();
  copy_in(s.x.data(), n_, x_, y_, z_, "positions");
  copy_in(s.v.data(), n_, vx_, vy_, vz_, "velocities");
  copy_in(s.w.data(), n_, wx_, wy_, wz_, "spins");
  copy_in(s.f.data(), n_, fx_, fy_, fz_, "forces");
  copy_in(s.t.data(), n_, tx_, ty_, tz_, "torques");
  copy_in(s.x_ref.data(), n_, x_ref_, y_ref_, z_ref_, "reference positions");
  // Every particle gets its own block for now; refresh_walls (below) keeps those near the drum.
  if (!wall_block_.empty()) {
    wall_history_ = s.wall_history;
    wall_lifter_ = s.wall_lifter;
    std::iota(wall_block_.begin(), wall_block_.end(), 0);
  }
  // Which slots are held follows from the history (a held slot whose history is exactly zero
  // behaves the same when cleared).
  for (std::size_t i = 0; i < wall_held_.size(); ++i) {
    unsigned held = 0;
    for (std::size_t slot = 0; slot < wall_slots; ++slot) {
      const double* h = &wall_history_[(i * wall_slots + slot) * history_size()];
      bool any = slot >= 3 && wall_lifter_[2 * i + slot - 3] >= 0;  // a lifter held
      for (std::size_t k = 0; k < history_size(); ++k) any = any || h[k] != 0.0;
      if (any) held |= 1u << slot;
    }
    wall_held_[i] = static_cast<std::uint8_t>(held);
  }
  step_ = s.step;
  rotation_start_ = s.rotation_start;
  last_sample_offset_ = s.last_sample_offset;
  sampling_ = SamplingState{};
  theta_ = s.theta;
  omega_ = s.omega;
  forces_valid_ = s.forces_valid;
  torque_ = s.torque;
  ledger_ = s.ledger;
  // Which lifters are in reach and who keeps wall history change no force: a fresh look is
  // valid (refresh_walls). With the list not yet built (an engine that never stepped), the
  // first step builds it, and splits the rows among the threads.
  if (list_.builds() > 0) {
    Access::list_touch_distances(*this);
    Access::split_rows(*this);
    Access::split_particles(*this);
    Access::refresh_walls(*this);
  }
}

void Engine::Access::rebuild(Engine& e) {
  rebuild_begin(e, 1);
  e.list_.build_rows(e.x_.data(), e.y_.data(), e.z_.data(), e.r_.data(), 1);
  rebuild_end(e);
}

void Engine::Access::rebuild_begin(Engine& e, int team) {
  const std::uint32_t* moved = nullptr;
  if (e.config_.reorder) {
    // Re-store the particles in cell order, then build: the list's history follows the
    // permutation. Forces and torques move too (the next half kick uses them); the pair
    // buffers and the dissipative sums are rewritten by every pair pass.
    e.list_moved_ =
        e.list_.spatial_order(e.x_.data(), e.y_.data(), e.z_.data(), e.r_.data(), e.n_);
    const std::vector<std::uint32_t>& from = e.list_moved_;
    std::vector<double> scratch;
    for (auto* a : {&e.x_, &e.y_, &e.z_, &e.vx_, &e.vy_, &e.vz_, &e.wx_, &e.wy_, &e.wz_, &e.fx_,
                    &e.fy_, &e.fz_, &e.tx_, &e.ty_, &e.tz_})
      permute(*a, from, 1, scratch);
    std::vector<std::int32_t> scratch_i32;
    permute(e.wall_block_, from, 1, scratch_i32);  // the blocks stay; refresh_walls re-packs
    std::vector<std::uint8_t> scratch_u8;
    permute(e.wall_held_, from, 1, scratch_u8);
    std::vector<std::uint32_t> scratch_u32;
    permute(e.order_, from, 1, scratch_u32);
    e.set_particle_constants();  // radius, material, mass, inverses follow from order_
    moved = e.list_moved_.data();
  }
  e.list_.begin_build(e.x_.data(), e.y_.data(), e.z_.data(), e.r_.data(), e.n_, moved, team);
}

void Engine::Access::rebuild_end(Engine& e) {
  e.list_.finish_build();
  neighbors::release(e.list_moved_);  // needed only during the build
  refresh_walls(e);
  for (std::size_t i = 0; i < e.n_; ++i) {
    e.x_ref_[i] = static_cast<float>(e.x_[i]);
    e.y_ref_[i] = static_cast<float>(e.y_[i]);
    e.z_ref_[i] = static_cast<float>(e.z_[i]);
  }
  list_touch_distances(e);
  split_rows(e);
  split_particles(e);
}

void Engine::Access::refresh_walls(Engine& e) {
  // Which particles may touch the drum, and which lifters, until the next refresh: only those
  // measure the distance to a lifter in the step kernel, and only those keep wall contact
  // history. Refreshed at every list build and whenever the drum has turned the shell by
  // skin/2 since the last refresh. Until the next one, a particle moves at most skin from where
  // it is now (it stays within skin/2 of its place at the last build, and so was it now) and a
  // lifter's surface at most skin/2 (it lies within the shell): a part of the drum not within
  // 1.5 skin now cannot be touched before the next refresh.
  const drum::Geometry& g = e.config_.geometry;
  e.lifter_angles_.update(g, e.theta_);
  e.reach_theta_ = e.theta_;
  const double margin = 1.5 * e.list_.skin();
  if (g.lifters > 0) {
    e.lifter_reach_.resize(e.n_);
    for (std::size_t i = 0; i < e.n_; ++i)
      e.lifter_reach_[i] = drum::lifter_reach(
          g, e.lifter_angles_, contact::Vec3(e.x_[i], e.y_[i], e.z_[i]), e.r_[i], margin);
  } else {
    e.lifter_reach_.clear();
  }
  if (e.wall_block_.empty()) return;  // no friction: no wall history
  // Blocks of wall history for the particles near the shell, an end wall or a lifter, and for
  // any that still holds a contact; packed in particle order, carried over from the old blocks.
  const std::size_t width = wall_slots * e.history_size();
  std::vector<std::int32_t> block(e.n_, -1);
  std::int32_t blocks = 0;
  for (std::size_t i = 0; i < e.n_; ++i) {
    bool near = e.wall_held_[i] != 0 ||
                near_shell_or_ends(g, e.x_[i], e.y_[i], e.z_[i], e.r_[i], margin);
    if (g.lifters > 0) near = near || e.lifter_reach_[i] != drum::no_lifter;
    if (near) block[i] = blocks++;
  }
  std::vector<double> history(static_cast<std::size_t>(blocks) * width, 0.0);
  std::vector<std::int32_t> lifter(2 * static_cast<std::size_t>(blocks), -1);
  for (std::size_t i = 0; i < e.n_; ++i) {
    const std::int32_t old = e.wall_block_[i];
    if (block[i] < 0 || old < 0) continue;
    const auto from = static_cast<std::size_t>(old), to = static_cast<std::size_t>(block[i]);
    std::copy_n(e.wall_history_.begin() + static_cast<std::ptrdiff_t>(from * width), width,
                history.begin() + static_cast<std::ptrdiff_t>(to * width));
    std::copy_n(e.wall_lifter_.begin() + static_cast<std::ptrdiff_t>(2 * from), 2,
                lifter.begin() + static_cast<std::ptrdiff_t>(2 * to));
  }
  e.wall_block_.swap(block);
  e.wall_history_.swap(history);
  e.wall_lifter_.swap(lifter);
}

// The two splits below are set at every list build and at a restore, from what a checkpoint
// holds (the list and the positions at its build, x_ref_): a restored run splits its work as
// the saved one did, and so sums in the same order, to the bit.

void Engine::Access::split_particles(Engine& e) {
  // The particles go to threads in contiguous blocks of about equal cost: 1 for a particle,
  // drum_contact_cost for one that touched the shell or an end wall at the list build.
  std::vector<double> cost(e.n_, 1.0);
  for (std::size_t i = 0; i < e.n_; ++i)
    if (near_shell_or_ends(e.config_.geometry, e.x_ref_[i], e.y_ref_[i], e.z_ref_[i], e.r_[i], 0.0))
      cost[i] = drum_contact_cost;
  split_by_cost(cost, static_cast<std::size_t>(e.threads_), e.particle_split_);
}

void Engine::Access::list_touch_distances(Engine& e) {
  const auto& start = e.list_.start();
  const auto& partner = e.list_.partner();
  e.touch_dist2_.assign(partner.size(), 0.0);
  for (std::size_t i = 0; i + 1 < start.size(); ++i) {
    for (std::uint32_t s = start[i]; s < start[i + 1]; ++s) {
      const double r_sum = e.r_[i] + e.r_[partner[s]];
      e.touch_dist2_[s] = r_sum * r_sum;
    }
  }
}

void Engine::Access::split_rows(Engine& e) {
  // Rows go to threads in contiguous blocks of about equal cost: a row costs 1 for each
  // listed pair, touching_pair_cost for one that touched at the list build.
  const auto& start = e.list_.start();
  const auto& partner = e.list_.partner();
  const std::size_t team = static_cast<std::size_t>(e.threads_);
  std::vector<double> cost(e.n_, 0.0);
  for (std::size_t i = 0; i + 1 < start.size(); ++i) {
    for (std::uint32_t s = start[i]; s < start[i + 1]; ++s) {
      const std::size_t j = partner[s];
      const double dx = static_cast<double>(e.x_ref_[i]) - e.x_ref_[j],
                   dy = static_cast<double>(e.y_ref_[i]) - e.y_ref_[j],
                   dz = e.list_.wrap_dz(static_cast<double>(e.z_ref_[i]) - e.z_ref_[j]);
      cost[i] += dx * dx + dy * dy + dz * dz < e.touch_dist2_[s] ? touching_pair_cost : 1.0;
    }
  }
  split_by_cost(cost, team, e.row_split_);
  // Thread t buffers what its rows give the particles after them, up to its last partner.
  for (std::size_t t = 0; t < team; ++t) {
    const std::size_t own_end = e.row_split_[t + 1];
    std::size_t end = own_end;
    for (std::size_t i = e.row_split_[t]; i < own_end; ++i)
      if (start[i + 1] > start[i]) end = std::max<std::size_t>(end, partner[start[i + 1] - 1] + 1u);
    e.buffer_end_[t] = end;
    e.buffers_[t].resize(e.buffer_width_ * (end - own_end));
  }
}

namespace {
/// When a guard stopped the run, on the time axis of the record: since the start of rotation
/// (a record's t), or since filling while the charge settles.
std::string when(const Engine& e) {
  std::ostringstream text;
  text.precision(6);
  const long start = e.rotation_start_step();
  if (start >= 0) {
    text << "t = " << static_cast<double>(e.step_count() - start) * e.dt()
         << " s since the start of rotation, the record's time";
  } else {
    text << "during settling, t = " << e.time() << " s since filling";
  }
  return text.str();
}
}  // namespace

std::string Engine::Access::describe_bad(const Engine& e, std::size_t i) {
  std::ostringstream msg;
  msg.precision(6);
  const double rho = std::hypot(e.x_[i], e.y_[i]);
  msg << "the simulation stopped at step " << e.step_ << " (" << when(e) << "): particle "
      << e.order_[i] << " (radius " << e.r_[i] << " m, material " << static_cast<int>(e.mat_[i]) << ") ";
  const double values[] = {e.x_[i], e.y_[i], e.z_[i], e.vx_[i], e.vy_[i], e.vz_[i],
                           e.fx_[i], e.fy_[i], e.fz_[i]};
  const bool finite = std::all_of(std::begin(values), std::end(values),
                                  [](double v) { return std::isfinite(v); }) &&
                      std::isfinite(e.wx_[i] + e.wy_[i] + e.wz_[i] + e.tx_[i] + e.ty_[i] + e.tz_[i]);
  const double speed = std::sqrt(e.vx_[i] * e.vx_[i] + e.vy_[i] * e.vy_[i] + e.vz_[i] * e.vz_[i]);
  if (!finite) {
    msg << "has non-finite values";
  } else if (rho > e.config_.geometry.radius) {
    msg << "has left the drum: its centre is " << rho << " m from the axis, beyond the shell at "
        << e.config_.geometry.radius << " m";
  } else {
    msg << "moves at " << speed << " m/s, above the bound of " << e.config_.max_speed
        << " m/s no particle of this scene can reach";
  }
  msg << " (position " << e.x_[i] << ", " << e.y_[i] << ", " << e.z_[i] << " m; velocity "
      << e.vx_[i] << ", " << e.vy_[i] << ", " << e.vz_[i] << " m/s; force " << e.fx_[i] << ", "
      << e.fy_[i] << ", " << e.fz_[i] << " N). Hint: the time step (" << e.dt_
      << " s) is probably too large for the contact stiffness or the impact speeds; try a "
         "smaller dt, or check the initial positions for large overlaps.";
  return msg.str();
}

std::string Engine::Access::describe_overlap(const Engine& e, std::size_t i, double ratio,
                                             bool wall) {
  std::ostringstream msg;
  msg.precision(6);
  msg << "the simulation stopped at step " << e.step_ << " (" << when(e) << "): particle "
      << e.order_[i] << " (radius " << e.r_[i] << " m, material " << static_cast<int>(e.mat_[i])
      << ") overlaps " << (wall ? "the drum" : "another particle") << " by " << ratio
      << " of the " << (wall ? "particle's" : "smaller") << " radius, above the limit of "
      << e.config_.max_overlap << " (position " << e.x_[i] << ", " << e.y_[i] << ", " << e.z_[i]
      << " m; velocity " << e.vx_[i] << ", " << e.vy_[i] << ", " << e.vz_[i]
      << " m/s). Hint: contacts this deep are outside Hertz theory; the time step (" << e.dt_
      << " s) may be too large for the impact speeds, the contacts too soft for them (a shear "
         "modulus reduced too far), or the initial positions overlap.";
  return msg.str();
}

}  // namespace millscope::engine
