// Fixed-step classical Runge-Kutta integration on an output grid, shared by
// the test beds' simulators.
//
// A System has `static const int NSTATE` and `rhs(double t, const double* y,
// double* dy)`. Its time argument runs on the grid's clock; the derivatives
// are taken with respect to a time `time_scale` times longer, so that a step
// of dt on the grid advances the state by h = dt * time_scale.
#ifndef WAVEVALID_RK4_H
#define WAVEVALID_RK4_H

namespace wavevalid {

// One RK4 step from grid time tc; tc is advanced by dt.
template <class System>
inline void rk4_step(const System& sys, double& tc, double dt, double h, double* y) {
  const int n = System::NSTATE;
  double k1[n], k2[n], k3[n], k4[n], tmp[n];
  sys.rhs(tc, y, k1);
  for (int i = 0; i < n; ++i) tmp[i] = y[i] + 0.5 * h * k1[i];
  sys.rhs(tc + 0.5 * dt, tmp, k2);
  for (int i = 0; i < n; ++i) tmp[i] = y[i] + 0.5 * h * k2[i];
  sys.rhs(tc + 0.5 * dt, tmp, k3);
  for (int i = 0; i < n; ++i) tmp[i] = y[i] + h * k3[i];
  sys.rhs(tc + dt, tmp, k4);
  for (int i = 0; i < n; ++i) y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
  tc += dt;
}

// Integrates from the zero state at t[0] with nsub steps per grid interval.
// `record(k, y)` is called at every grid point t[k] (k = 0 before any step)
// and returns false to stop: rk4_grid then returns false.
template <class System, class Record>
inline bool rk4_grid(const System& sys, const double* t, int nt, int nsub, double time_scale,
                     Record record) {
  const int n = System::NSTATE;
  double y[n] = {0};
  if (!record(0, y)) return false;
  for (int k = 1; k < nt; ++k) {
    const double dt = (t[k] - t[k - 1]) / nsub;
    const double h = dt * time_scale;
    double tc = t[k - 1];
    for (int j = 0; j < nsub; ++j) rk4_step(sys, tc, dt, h, y);
    if (!record(k, y)) return false;
  }
  return true;
}

}  // namespace wavevalid

#endif
