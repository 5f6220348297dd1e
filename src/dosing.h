// Pharmacokinetic dosing model: plasma concentration after repeated oral doses.
//
// Two-compartment model with first-order absorption and five states: the
// amount in the gut Ag, in the central (plasma) compartment Ac, in the
// peripheral compartment Ap and in the bile Ab (mg), and an enzyme-induction
// state E (dimensionless, in [0, 1)). With C = Ac / V (mg/L):
//
//   dAg/dt = F D sum_d phi(t - t_d - s_lag LAG) + k_gb(t) Ab - ka Ag
//   dAc/dt = ka Ag - e(t) - Q (C - Ap / Vp)
//   dAp/dt = Q (C - Ap / Vp)
//   dAb/dt = s_rec BILE_FRACTION e(t) - k_gb(t) Ab
//   dE/dt  = (C / (C + INDUCTION_EC50) - E) / INDUCTION_TAU
//
// where e(t) = CL (1 + s_ind INDUCTION_MAX E) C / (1 + s_sat C / KM) is the
// elimination rate (mg/h), phi a normal density of standard deviation
// DOSE_SD (the dissolution of each tablet), and k_gb(t) = GB_RATE
// sum_d exp(-(t - t_d - GB_DELAY)^2 / (2 GB_SD^2)) the emptying rate of the
// gall bladder at the meal that follows each dose. The four mechanisms,
// each with a strength s in [0, 1]: saturable (Michaelis-Menten) elimination,
// enterohepatic recycling (a share of the eliminated drug goes to the bile and
// returns to the gut when the gall bladder empties), an absorption lag, and
// induction of the clearance by the drug itself. At s = 0 every mechanism
// term vanishes exactly.
//
// An added term (testbed_term.h) s_term * f(x) of one state x (C, Ag, Ac,
// Ap, Ab or E, in the units above) is an extra elimination rate (mg/h) from
// the central compartment: dAc/dt -= s_term f(x). It does not go to the bile.
#ifndef WAVEVALID_DOSING_H
#define WAVEVALID_DOSING_H

#include <cmath>
#include <cstddef>

#include "rk4.h"
#include "testbed_term.h"

namespace wavevalid {
namespace dosing {

const double PI = 3.14159265358979323846;
const double DOSE_SD = 0.1;           // h, spread of a tablet's dissolution
const double KM = 10.0;               // mg/L, Michaelis constant of saturable elimination
const double BILE_FRACTION = 0.5;     // share of the elimination going to the bile
const double GB_DELAY = 4.0;          // h from a dose to the gall bladder's emptying
const double GB_SD = 0.3;             // h, duration of the emptying
const double GB_RATE = 3.0;           // 1/h, peak emptying rate
const double LAG = 0.75;              // h, absorption lag at strength 1
const double INDUCTION_EC50 = 3.0;    // mg/L
const double INDUCTION_TAU = 36.0;    // h, time constant of the induction
const double INDUCTION_MAX = 1.5;     // rise of the clearance at full induction

// Order of the physical parameter vector passed by the R front end.
enum ParamIndex {
  P_CL = 0,  // clearance (L/h)
  P_KA,      // absorption rate (1/h)
  P_V,       // central volume (L)
  P_F,       // bioavailability
  P_Q,       // intercompartmental clearance (L/h)
  P_VP,      // peripheral volume (L)
  N_PARAMS
};

// States an added term can be a function of; the recorded state histories
// are those of TERM_GUT..TERM_CONCENTRATION in this order (N_RECORDED).
enum TermState { TERM_CONCENTRATION = 0, TERM_GUT, TERM_CENTRAL, TERM_PERIPHERAL, TERM_BILE, TERM_INDUCTION };
const int N_RECORDED = 6;

struct Strength {
  double saturable = 0.0, recycling = 0.0, lag = 0.0, induction = 0.0;
};

class Patient {
 public:
  static const int NSTATE = 5;
  Patient(const double* p, const Strength& s, const double* doses, int n_doses, double dose_mg,
          const AddedTerm& term = AddedTerm())
      : p_(p), s_(s), doses_(doses), nd_(n_doses), dose_(dose_mg), term_(term) {}

  double concentration(const double* y) const { return y[1] / p_[P_V]; }

  void rhs(double t, const double* y, double* dy) const {
    double input = 0.0, kgb = 0.0;
    const double norm = 1.0 / (DOSE_SD * std::sqrt(2.0 * PI));
    for (int d = 0; d < nd_; ++d) {
      const double a = (t - doses_[d] - s_.lag * LAG) / DOSE_SD;
      input += norm * std::exp(-0.5 * a * a);
      const double b = (t - doses_[d] - GB_DELAY) / GB_SD;
      kgb += GB_RATE * std::exp(-0.5 * b * b);
    }
    input *= p_[P_F] * dose_;
    const double c = y[1] / p_[P_V];
    const double cl = p_[P_CL] * (1.0 + s_.induction * INDUCTION_MAX * y[4]);
    const double elim = cl * c / (1.0 + s_.saturable * c / KM);
    const double dist = p_[P_Q] * (c - y[2] / p_[P_VP]);
    const double absorbed = p_[P_KA] * y[0];
    const double emptied = kgb * y[3];
    dy[0] = input + emptied - absorbed;
    dy[1] = absorbed - elim - dist;
    if (term_.state >= 0 && term_.acts_on(term_.state)) dy[1] -= term_(term_value(c, y));
    dy[2] = dist;
    dy[3] = s_.recycling * BILE_FRACTION * elim - emptied;
    dy[4] = (c / (c + INDUCTION_EC50) - y[4]) / INDUCTION_TAU;
  }

  // The recorded states Ag, Ac, Ap, Ab, E and C of state y.
  void recorded(const double* y, double* out) const {
    for (int i = 0; i < NSTATE; ++i) out[i] = y[i];
    out[NSTATE] = concentration(y);
  }

 private:
  const double* p_;
  Strength s_;
  const double* doses_;
  int nd_;
  double dose_;
  AddedTerm term_;

  // The added term's state at concentration c and state y.
  double term_value(double c, const double* y) const {
    return term_.state == TERM_CONCENTRATION ? c : y[term_.state - 1];
  }
};

// Integrates from rest at t[0] with nsub RK4 steps per grid interval and
// writes the plasma concentration (mg/L) at t[k] to conc[k * stride]; with
// `states` (NULL or N_RECORDED pointers), the recorded states go to
// states[i][k * stride]. Returns false if the solution stops being finite.
inline bool simulate(const double* params, const Strength& s, const AddedTerm& term, const double* doses,
                     int n_doses, double dose_mg, const double* t, int nt, int nsub, double* conc,
                     std::ptrdiff_t stride, double* const* states = nullptr) {
  const Patient pt(params, s, doses, n_doses, dose_mg, term);
  return rk4_grid(pt, t, nt, nsub, 1.0, [&](int k, const double* y) {
    const double c = pt.concentration(y);
    if (k > 0 && !std::isfinite(c)) return false;
    conc[k * stride] = c;
    if (states != nullptr) {
      double rec[N_RECORDED];
      pt.recorded(y, rec);
      for (int i = 0; i < N_RECORDED; ++i) states[i][k * stride] = rec[i];
    }
    return true;
  });
}

}  // namespace dosing
}  // namespace wavevalid

#endif
