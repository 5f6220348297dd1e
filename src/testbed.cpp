// R glue for the test beds: the suspension and the dosing simulators.
//
// Both simulators take an optional added term (testbed_term.h): the index
// `term_state` of the state it is a function of (-1: no term, the default),
// `term_range` (x0, x1) and `term_table` (the function's values on
// equally spaced points from x0 to x1, at least two), and `term_strength`, one
// strength per run. With `states = true`, the returned list carries the
// attribute "states": a list of K x T matrices of the recorded state
// histories (rows of NA for a run that blew up).
#include <Rcpp.h>
#include <string>
#include <vector>

#include "dosing.h"
#include "suspension.h"
#include "testbed_term.h"

namespace {

// The added term of run k (its strength from term_strength[k]).
wavevalid::AddedTerm term_of_run(int state, const Rcpp::NumericVector& range, const Rcpp::NumericVector& table,
                                 const Rcpp::NumericVector& strength, int k) {
  wavevalid::AddedTerm term;
  if (state < 0) return term;
  term.state = state;
  term.y = &table[0];
  term.n = table.size();
  term.x0 = range[0];
  term.x1 = range[1];
  term.strength = strength[k];
  return term;
}

void check_term(int state, int n_states, const Rcpp::NumericVector& range, const Rcpp::NumericVector& table,
                const Rcpp::NumericVector& strength, int K) {
  if (state < 0) return;
  if (state >= n_states) Rcpp::stop("term_state must be below %d", n_states);
  if (range.size() != 2 || !(range[1] > range[0])) Rcpp::stop("term_range must be two increasing numbers");
  if (table.size() < 2) Rcpp::stop("term_table must hold at least two values");
  if (strength.size() != K) Rcpp::stop("term_strength must hold one strength per run");
}

// n matrices K x nt for the recorded states and pointers to their rows k.
struct Recorded {
  std::vector<Rcpp::NumericMatrix> m;
  std::vector<double*> row;
  Recorded(bool on, int n, int K, int nt) {
    if (!on) return;
    for (int i = 0; i < n; ++i) m.push_back(Rcpp::NumericMatrix(K, nt));
    row.resize(n);
  }
  double* const* at(int k) {
    if (m.empty()) return nullptr;
    for (std::size_t i = 0; i < m.size(); ++i) row[i] = &m[i](k, 0);
    return row.data();
  }
  void fail(int k) {
    for (auto& x : m) {
      for (int j = 0; j < x.ncol(); ++j) x(k, j) = NA_REAL;
    }
  }
  Rcpp::List list(const std::vector<std::string>& names) const {
    Rcpp::List out(m.size());
    for (std::size_t i = 0; i < m.size(); ++i) out[i] = m[i];
    out.attr("names") = names;
    return out;
  }
};

}  // namespace

// Simulates every row of `params` (K x 18 physical parameters, in the order of
// wavevalid::suspension::ParamIndex) with the mechanism strengths in the
// matching row of `strength` (K x 4: lift-off, friction, digressive,
// progressive). Returns list(site1 = K x T, site2 = K x T) of strut loads in
// kN; a run that blows up is returned as a row of NA. The term's states are
// those of wavevalid::suspension::TermState; the recorded states are the
// compression (m), compression velocity (m/s), damper force (kN) and tire
// force (kN) of the front and rear struts.
// [[Rcpp::export]]
Rcpp::List suspension_simulate_cpp(const Rcpp::NumericMatrix& params,
                                   const Rcpp::NumericMatrix& strength,
                                   const Rcpp::NumericVector& t, int nsub, int term_state = -1,
                                   Rcpp::NumericVector term_range = Rcpp::NumericVector::create(),
                                   Rcpp::NumericVector term_table = Rcpp::NumericVector::create(),
                                   Rcpp::NumericVector term_strength = Rcpp::NumericVector::create(),
                                   bool states = false) {
  namespace ws = wavevalid::suspension;
  const int K = params.nrow(), nt = t.size();
  if (params.ncol() != ws::N_PARAMS) Rcpp::stop("params must have %d columns", ws::N_PARAMS);
  if (strength.nrow() != K || strength.ncol() != 4) Rcpp::stop("strength must be K x 4");
  if (nt < 2) Rcpp::stop("t must have at least two points");
  if (nsub < 1) Rcpp::stop("nsub must be positive");
  check_term(term_state, 4, term_range, term_table, term_strength, K);
  Rcpp::NumericMatrix front(K, nt), rear(K, nt);
  Recorded rec(states, ws::N_RECORDED, K, nt);
  std::vector<double> p(ws::N_PARAMS);
  for (int k = 0; k < K; ++k) {
    for (int i = 0; i < ws::N_PARAMS; ++i) p[i] = params(k, i);
    ws::Strength s;
    s.liftoff = strength(k, 0);
    s.friction = strength(k, 1);
    s.digressive = strength(k, 2);
    s.progressive = strength(k, 3);
    const wavevalid::AddedTerm term = term_of_run(term_state, term_range, term_table, term_strength, k);
    bool ok = ws::simulate(p.data(), s, term, &t[0], nt, nsub, &front(k, 0), &rear(k, 0), K, rec.at(k));
    if (!ok) {
      for (int j = 0; j < nt; ++j) {
        front(k, j) = NA_REAL;
        rear(k, j) = NA_REAL;
      }
      rec.fail(k);
    }
    if (k % 8 == 7) Rcpp::checkUserInterrupt();
  }
  Rcpp::List out = Rcpp::List::create(Rcpp::Named("site1") = front, Rcpp::Named("site2") = rear);
  if (states) {
    out.attr("states") = rec.list({"compression_front", "compression_rear", "velocity_front", "velocity_rear",
                                   "damper_front", "damper_rear", "tire_front", "tire_rear"});
  }
  return out;
}

// The tabulated road profile (m) at positions x (m).
// [[Rcpp::export]]
Rcpp::NumericVector suspension_road_cpp(const Rcpp::NumericVector& x) {
  const wavevalid::suspension::Road& rd = wavevalid::suspension::road();
  Rcpp::NumericVector out(x.size());
  for (R_xlen_t i = 0; i < x.size(); ++i) out[i] = rd(x[i]);
  return out;
}

// Simulates every row of `params` (K x 6 physical parameters, in the order of
// wavevalid::dosing::ParamIndex) with the mechanism strengths in the matching
// row of `strength` (K x 4: saturable elimination, enterohepatic recycling,
// absorption lag, induction), doses of `dose_mg` at the times `doses`
// (one amount for every run, or one per run).
// Returns list(plasma = K x T) of concentrations in mg/L; a run that blows up
// is returned as a row of NA. The term's states are those of
// wavevalid::dosing::TermState; the recorded states are the amounts in the
// gut, central, peripheral compartments and the bile (mg), the induction
// state and the concentration (mg/L).
// [[Rcpp::export]]
Rcpp::List dosing_simulate_cpp(const Rcpp::NumericMatrix& params,
                               const Rcpp::NumericMatrix& strength,
                               const Rcpp::NumericVector& doses, const Rcpp::NumericVector& dose_mg,
                               const Rcpp::NumericVector& t, int nsub, int term_state = -1,
                               Rcpp::NumericVector term_range = Rcpp::NumericVector::create(),
                               Rcpp::NumericVector term_table = Rcpp::NumericVector::create(),
                               Rcpp::NumericVector term_strength = Rcpp::NumericVector::create(),
                               bool states = false) {
  namespace wd = wavevalid::dosing;
  const int K = params.nrow(), nt = t.size(), nd = doses.size();
  if (params.ncol() != wd::N_PARAMS) Rcpp::stop("params must have %d columns", wd::N_PARAMS);
  if (strength.nrow() != K || strength.ncol() != 4) Rcpp::stop("strength must be K x 4");
  if (nt < 2) Rcpp::stop("t must have at least two points");
  if (nd < 1) Rcpp::stop("doses must hold at least one time");
  if (nsub < 1) Rcpp::stop("nsub must be positive");
  if (dose_mg.size() != 1 && dose_mg.size() != K) Rcpp::stop("dose_mg must hold one amount or one per run");
  check_term(term_state, 6, term_range, term_table, term_strength, K);
  Rcpp::NumericMatrix plasma(K, nt);
  Recorded rec(states, wd::N_RECORDED, K, nt);
  std::vector<double> p(wd::N_PARAMS);
  for (int k = 0; k < K; ++k) {
    for (int i = 0; i < wd::N_PARAMS; ++i) p[i] = params(k, i);
    wd::Strength s;
    s.saturable = strength(k, 0);
    s.recycling = strength(k, 1);
    s.lag = strength(k, 2);
    s.induction = strength(k, 3);
    const wavevalid::AddedTerm term = term_of_run(term_state, term_range, term_table, term_strength, k);
    bool ok = wd::simulate(p.data(), s, term, &doses[0], nd, dose_mg[dose_mg.size() == 1 ? 0 : k], &t[0], nt, nsub,
                           &plasma(k, 0), K, rec.at(k));
    if (!ok) {
      for (int j = 0; j < nt; ++j) plasma(k, j) = NA_REAL;
      rec.fail(k);
    }
    if (k % 8 == 7) Rcpp::checkUserInterrupt();
  }
  Rcpp::List out = Rcpp::List::create(Rcpp::Named("plasma") = plasma);
  if (states) {
    out.attr("states") = rec.list({"gut", "central", "peripheral", "bile", "induction", "concentration"});
  }
  return out;
}
