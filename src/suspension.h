// Half-car suspension model driven over a proving-ground course.
//
// Pitch-plane model with 10 states: body heave z and pitch th (nose up
// positive), front and rear unsprung heave zuf, zur, their velocities, and the
// forces Fdf, Fdr of the two dampers, each mounted in series with a rubber
// top-mount bushing (a Maxwell element: dFd/dt = kb (v_strut - v_damper)).
// Displacements are measured from static equilibrium; the strut load reported
// at each site is the total force in the strut (static preload + spring +
// damper + bump stop + friction), in kN.
//
// The course: constant speed over a fixed rough road (a sum of sinusoids with
// an ISO 8608 class B-C spectrum, phases from a fixed seed, identical for
// every run) with a pothole met by the front wheel at course time 7.2 and a
// bump at course time 38; the rear wheel meets everything one wheelbase
// later. Course time t relates to physical time by s = TIME_SCALE * t.
//
// Four mechanisms can be switched on with a strength s in [0, 1]:
// tire lift-off (the tire cannot pull the wheel down: at s = 1 a negative
// tire force is set to zero), strut friction (smoothed Coulomb friction
// s * FRICTION_F0 * v / sqrt(v^2 + FRICTION_VEPS^2) newtons at strut
// velocity v), digressive damper (above a knee velocity the damping slope
// drops from c to c * (1 - s * (1 - DIGRESSIVE_RATIO))) and
// progressive bump stop (force k p (1 + s p / PROGRESSIVE_P0) at penetration p).
//
// An added term (testbed_term.h) s_term * f(x) acts at both axles, each with
// its own axle's state x: a force f(d) or f(v) (kN) added to the strut force
// (TERM_COMPRESSION, TERM_VELOCITY; it enters the reported strut load), a
// velocity f(Fd) (m/s, Fd in kN) added to the damper's velocity law
// (TERM_DAMPER), or a force f(Ft) (kN, Ft the tire's force before the term,
// in kN) added to the tire force (TERM_TIRE).
#ifndef WAVEVALID_SUSPENSION_H
#define WAVEVALID_SUSPENSION_H

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "rk4.h"
#include "testbed_term.h"

namespace wavevalid {
namespace suspension {

// ---- course and reality constants -----------------------------------------
const double GRAVITY = 9.81;
const double SPEED = 8.0;            // m/s
const double TIME_SCALE = 0.25;      // physical seconds per course time unit
const double WHEELBASE_A = 1.2;      // CG to front axle (m)
const double WHEELBASE_B = 1.5;      // CG to rear axle (m)
const double POTHOLE_T = 6.8;        // course time the front wheel meets the pothole
const double POTHOLE_LENGTH = 0.55;  // m
const double POTHOLE_DEPTH = 0.07;   // m
const double POTHOLE_EDGE = 0.08;    // m, width of the smoothed edges
const double BUMP_T = 37.5;          // course time the front wheel meets the bump
const double BUMP_LENGTH = 0.7;      // m
const double BUMP_HEIGHT = 0.065;    // m
const double ROAD_X0 = -4.0;         // first point of the tabulated road (m)
const double ROAD_X1 = 140.0;        // last point (m)
const double ROAD_DX = 0.01;         // tabulation step (m)
const double ROUGH_G0 = 6.0e-6;     // displacement PSD at 0.1 cycle/m (m^3)
const int ROUGH_N = 256;             // number of sinusoids
const double ROUGH_NMIN = 0.03;      // cycles/m
const double ROUGH_NMAX = 2.5;       // cycles/m
const std::uint64_t ROUGH_SEED = 20070301ULL;

const double FRICTION_F0 = 400.0;      // N, Coulomb friction at strength 1
const double FRICTION_VEPS = 0.01;     // m/s, smoothing velocity
const double DIGRESSIVE_KNEE = 0.35;   // m/s, knee of the damper law
const double DIGRESSIVE_RATIO = 0.4;   // high-speed slope / low-speed slope at strength 1
const double PROGRESSIVE_P0 = 0.03;    // m, bump-stop penetration doubling the stiffness

// ---- parameters -------------------------------------------------------------
// Order of the physical parameter vector passed by the R front end.
enum ParamIndex {
  P_MS = 0,   // sprung mass (kg)
  P_IY,       // pitch inertia (kg m^2)
  P_MUF,      // front unsprung mass (kg)
  P_MUR,      // rear unsprung mass (kg)
  P_KTF,      // front tire stiffness (N/m)
  P_KTR,      // rear tire stiffness
  P_KSF,      // front spring stiffness
  P_KSR,      // rear spring stiffness
  P_KBF,      // front top-mount bushing stiffness
  P_KBR,      // rear top-mount bushing stiffness
  P_CCF,      // front compression damping (N s/m)
  P_CRF,      // front rebound damping
  P_CCR,      // rear compression damping
  P_CRR,      // rear rebound damping
  P_KBSF,     // front bump-stop stiffness (N/m)
  P_KBSR,     // rear bump-stop stiffness
  P_GAPF,     // front bump-stop clearance (m)
  P_GAPR,     // rear bump-stop clearance
  N_PARAMS
};

// States an added term can be a function of.
enum TermState { TERM_COMPRESSION = 0, TERM_VELOCITY, TERM_DAMPER, TERM_TIRE };

// The state histories recorded at each grid point, in this order:
// compression d (m) and compression velocity v (m/s) of the front and rear
// struts, damper forces (kN), tire forces (kN, the term included).
const int N_RECORDED = 8;

struct Strength {
  double liftoff = 0.0;
  double friction = 0.0;
  double digressive = 0.0;
  double progressive = 0.0;
};

// ---- road -------------------------------------------------------------------
inline std::uint64_t splitmix64(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

inline double unit_uniform(std::uint64_t& s) {
  return (splitmix64(s) >> 11) * (1.0 / 9007199254740992.0);
}

inline double smoothstep(double u) {
  if (u <= 0.0) return 0.0;
  if (u >= 1.0) return 1.0;
  return u * u * (3.0 - 2.0 * u);
}

// Position of the front wheel at course time t.
inline double front_position(double t) { return SPEED * TIME_SCALE * t; }

// Deterministic event shapes (m) at road position x.
inline double event_height(double x) {
  const double xp = front_position(POTHOLE_T);
  double h = 0.0;
  if (x > xp && x < xp + POTHOLE_LENGTH) {
    h -= POTHOLE_DEPTH * smoothstep((x - xp) / POTHOLE_EDGE) *
         smoothstep((xp + POTHOLE_LENGTH - x) / POTHOLE_EDGE);
  }
  const double xb = front_position(BUMP_T);
  if (x > xb && x < xb + BUMP_LENGTH) {
    const double s = std::sin(M_PI * (x - xb) / BUMP_LENGTH);
    h += BUMP_HEIGHT * s * s;
  }
  return h;
}

// The road profile tabulated every ROAD_DX metres: roughness faded in over
// the first metres (so that the vehicle starts at rest on level ground) plus
// the two events. Built once, the same for every run.
class Road {
 public:
  Road() {
    const int n = static_cast<int>(std::lround((ROAD_X1 - ROAD_X0) / ROAD_DX)) + 1;
    h_.assign(n, 0.0);
    std::uint64_t state = ROUGH_SEED;
    const double lmin = std::log(ROUGH_NMIN), lmax = std::log(ROUGH_NMAX);
    const double dl = (lmax - lmin) / ROUGH_N;
    for (int i = 0; i < ROUGH_N; ++i) {
      const double lo = std::exp(lmin + i * dl), hi = std::exp(lmin + (i + 1) * dl);
      const double freq = lo + (hi - lo) * unit_uniform(state);
      const double psd = ROUGH_G0 * std::pow(freq / 0.1, -2.0);
      const double amp = std::sqrt(2.0 * psd * (hi - lo));
      const double phase = 2.0 * M_PI * unit_uniform(state);
      const double w = 2.0 * M_PI * freq;
      // Rotation recurrence for sin(w x + phase) along the grid.
      const double c = std::cos(w * ROAD_DX), s = std::sin(w * ROAD_DX);
      double sn = std::sin(w * ROAD_X0 + phase), cs = std::cos(w * ROAD_X0 + phase);
      for (int j = 0; j < n; ++j) {
        h_[j] += amp * sn;
        const double sn2 = sn * c + cs * s;
        cs = cs * c - sn * s;
        sn = sn2;
      }
    }
    for (int j = 0; j < n; ++j) {
      const double x = ROAD_X0 + j * ROAD_DX;
      h_[j] = h_[j] * smoothstep((x + 3.0) / 6.0) + event_height(x);
    }
  }

  double operator()(double x) const {
    double u = (x - ROAD_X0) / ROAD_DX;
    if (u <= 0.0) return h_.front();
    const int last = static_cast<int>(h_.size()) - 1;
    if (u >= last) return h_.back();
    const int j = static_cast<int>(u);
    const double f = u - j;
    return h_[j] * (1.0 - f) + h_[j + 1] * f;
  }

  const std::vector<double>& values() const { return h_; }

 private:
  std::vector<double> h_;
};

inline const Road& road() {
  static const Road r;
  return r;
}

// ---- vehicle ----------------------------------------------------------------
class HalfCar {
 public:
  static const int NSTATE = 10;

  HalfCar(const double* p, const Strength& s, const AddedTerm& term = AddedTerm()) : s_(s), term_(term) {
    for (int i = 0; i < N_PARAMS; ++i) p_[i] = p[i];
    const double L = WHEELBASE_A + WHEELBASE_B;
    preload_f_ = p_[P_MS] * GRAVITY * WHEELBASE_B / L;
    preload_r_ = p_[P_MS] * GRAVITY * WHEELBASE_A / L;
  }

  // Total strut force (N), compression positive, at strut compression d,
  // compression velocity v and damper force fd.
  double strut_force(double d, double v, double fd, double preload, double ks, double kbs,
                     double gap) const {
    double f = preload + ks * d + fd;
    const double pen = d - gap;
    if (pen > 0.0) f += kbs * pen * (1.0 + s_.progressive * pen / PROGRESSIVE_P0);
    if (s_.friction > 0.0) f += s_.friction * FRICTION_F0 * v / std::sqrt(v * v + FRICTION_VEPS * FRICTION_VEPS);
    if (term_.acts_on(TERM_COMPRESSION)) f += 1000.0 * term_(d);
    if (term_.acts_on(TERM_VELOCITY)) f += 1000.0 * term_(v);
    return f;
  }

  // Damper velocity producing damper force f (inverse of the damper law).
  double damper_velocity(double f, double cc, double cr) const {
    const double v = damper_law(f, cc, cr);
    return term_.acts_on(TERM_DAMPER) ? v + term_(f / 1000.0) : v;
  }

  double damper_law(double f, double cc, double cr) const {
    const double c = f >= 0.0 ? cc : cr;
    const double fk = c * DIGRESSIVE_KNEE;
    const double af = std::fabs(f);
    if (af <= fk) return f / c;
    const double slope = c * (1.0 - s_.digressive * (1.0 - DIGRESSIVE_RATIO));
    const double v = DIGRESSIVE_KNEE + (af - fk) / slope;
    return f >= 0.0 ? v : -v;
  }

  double tire_force(double defl, double preload, double kt) const {
    double f = preload + kt * defl;
    if (f < 0.0) f *= (1.0 - s_.liftoff);
    if (term_.acts_on(TERM_TIRE)) f += 1000.0 * term_(f / 1000.0);
    return f;
  }

  // Right-hand side at course time t (derivatives with respect to physical time).
  void rhs(double t, const double* y, double* dy) const {
    const Road& rd = road();
    const double a = WHEELBASE_A, b = WHEELBASE_B;
    const double xf = front_position(t);
    const double rf = rd(xf), rr = rd(xf - a - b);
    const double z = y[0], th = y[1], zuf = y[2], zur = y[3];
    const double vz = y[4], vth = y[5], vuf = y[6], vur = y[7];
    const double fdf = y[8], fdr = y[9];
    const double df = zuf - (z + a * th), dr = zur - (z - b * th);
    const double vf = vuf - (vz + a * vth), vr = vur - (vz - b * vth);
    const double ff = strut_force(df, vf, fdf, preload_f_, p_[P_KSF], p_[P_KBSF], p_[P_GAPF]);
    const double fr = strut_force(dr, vr, fdr, preload_r_, p_[P_KSR], p_[P_KBSR], p_[P_GAPR]);
    const double tf = tire_force(rf - zuf, preload_f_ + p_[P_MUF] * GRAVITY, p_[P_KTF]);
    const double tr = tire_force(rr - zur, preload_r_ + p_[P_MUR] * GRAVITY, p_[P_KTR]);
    dy[0] = vz;
    dy[1] = vth;
    dy[2] = vuf;
    dy[3] = vur;
    dy[4] = (ff + fr) / p_[P_MS] - GRAVITY;
    dy[5] = (a * ff - b * fr) / p_[P_IY];
    dy[6] = (tf - ff) / p_[P_MUF] - GRAVITY;
    dy[7] = (tr - fr) / p_[P_MUR] - GRAVITY;
    dy[8] = p_[P_KBF] * (vf - damper_velocity(fdf, p_[P_CCF], p_[P_CRF]));
    dy[9] = p_[P_KBR] * (vr - damper_velocity(fdr, p_[P_CCR], p_[P_CRR]));
  }

  // Strut loads (kN) at the two sites for state y.
  void loads(const double* y, double* out) const {
    const double a = WHEELBASE_A, b = WHEELBASE_B;
    const double df = y[2] - (y[0] + a * y[1]), dr = y[3] - (y[0] - b * y[1]);
    const double vf = y[6] - (y[4] + a * y[5]), vr = y[7] - (y[4] - b * y[5]);
    out[0] = strut_force(df, vf, y[8], preload_f_, p_[P_KSF], p_[P_KBSF], p_[P_GAPF]) / 1000.0;
    out[1] = strut_force(dr, vr, y[9], preload_r_, p_[P_KSR], p_[P_KBSR], p_[P_GAPR]) / 1000.0;
  }

  // The N_RECORDED state histories' values at course time t for state y.
  void recorded(double t, const double* y, double* out) const {
    const Road& rd = road();
    const double a = WHEELBASE_A, b = WHEELBASE_B;
    const double xf = front_position(t);
    out[0] = y[2] - (y[0] + a * y[1]);
    out[1] = y[3] - (y[0] - b * y[1]);
    out[2] = y[6] - (y[4] + a * y[5]);
    out[3] = y[7] - (y[4] - b * y[5]);
    out[4] = y[8] / 1000.0;
    out[5] = y[9] / 1000.0;
    out[6] = tire_force(rd(xf) - y[2], preload_f_ + p_[P_MUF] * GRAVITY, p_[P_KTF]) / 1000.0;
    out[7] = tire_force(rd(xf - a - b) - y[3], preload_r_ + p_[P_MUR] * GRAVITY, p_[P_KTR]) / 1000.0;
  }

 private:
  double p_[N_PARAMS];
  Strength s_;
  AddedTerm term_;
  double preload_f_, preload_r_;
};

// Simulates one run from static equilibrium at t[0] and writes the loads at
// the course times t[0..nt-1] to front[k * stride] and rear[k * stride].
// Each output interval is split into nsub RK4 steps. With `states` (NULL or
// N_RECORDED pointers), the recorded states go to states[i][k * stride].
// Returns false if the solution blew up (non-finite state).
inline bool simulate(const double* params, const Strength& s, const AddedTerm& term, const double* t,
                     int nt, int nsub, double* front, double* rear, std::ptrdiff_t stride,
                     double* const* states = nullptr) {
  const HalfCar car(params, s, term);
  return rk4_grid(car, t, nt, nsub, TIME_SCALE, [&](int k, const double* y) {
    double out[2];
    car.loads(y, out);
    if (k > 0 && (!std::isfinite(out[0]) || !std::isfinite(out[1]))) return false;
    front[k * stride] = out[0];
    rear[k * stride] = out[1];
    if (states != nullptr) {
      double rec[N_RECORDED];
      car.recorded(t[k], y, rec);
      for (int i = 0; i < N_RECORDED; ++i) states[i][k * stride] = rec[i];
    }
    return true;
  });
}

}  // namespace suspension
}  // namespace wavevalid

#endif
