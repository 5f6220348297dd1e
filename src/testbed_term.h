// An added term of the test beds' simulators: a function of one state,
// tabulated by the R front end on equally spaced points, times a strength.
//
// The table holds the values y[0..n-1] of the function at x0 + i (x1 - x0) /
// (n - 1). Between the points the function is interpolated linearly; outside
// [x0, x1] it is extrapolated linearly from the two end points. The state is
// an index whose meaning is the simulator's (suspension.h, dosing.h); -1
// means no term. A term of strength 0 is never evaluated, so that the
// simulator's numbers are exactly those without it.
#ifndef WAVEVALID_TESTBED_TERM_H
#define WAVEVALID_TESTBED_TERM_H

#include <cmath>

namespace wavevalid {

struct AddedTerm {
  int state = -1;
  const double* y = nullptr;
  int n = 0;
  double x0 = 0.0, x1 = 1.0;
  double strength = 0.0;

  // Whether the term acts on `which` (a state index of the simulator).
  bool acts_on(int which) const { return state == which && strength != 0.0 && n >= 2; }

  // strength * f(v), f interpolated from the table.
  double operator()(double v) const {
    const double dx = (x1 - x0) / (n - 1);
    const double u = (v - x0) / dx;
    int j = 0;  // also for a non-finite v: the result is then not finite
    if (u >= n - 2) {
      j = n - 2;
    } else if (u > 0.0) {
      j = static_cast<int>(u);
    }
    const double f = u - j;
    return strength * (y[j] + f * (y[j + 1] - y[j]));
  }
};

}  // namespace wavevalid

#endif
