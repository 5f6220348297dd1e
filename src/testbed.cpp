// R glue for the test beds: the suspension and the dosing simulators.
#include <Rcpp.h>
#include <vector>

#include "dosing.h"
#include "suspension.h"

// Simulates every row of `params` (K x 18 physical parameters, in the order of
// wavevalid::suspension::ParamIndex) with the mechanism strengths in the
// matching row of `strength` (K x 4: lift-off, friction, digressive,
// progressive). Returns list(site1 = K x T, site2 = K x T) of strut loads in
// kN; a run that blows up is returned as a row of NA.
// [[Rcpp::export]]
Rcpp::List suspension_simulate_cpp(const Rcpp::NumericMatrix& params,
                                   const Rcpp::NumericMatrix& strength,
                                   const Rcpp::NumericVector& t, int nsub) {
  namespace ws = wavevalid::suspension;
  const int K = params.nrow(), nt = t.size();
  if (params.ncol() != ws::N_PARAMS) Rcpp::stop("params must have %d columns", ws::N_PARAMS);
  if (strength.nrow() != K || strength.ncol() != 4) Rcpp::stop("strength must be K x 4");
  if (nt < 2) Rcpp::stop("t must have at least two points");
  if (nsub < 1) Rcpp::stop("nsub must be positive");
  Rcpp::NumericMatrix front(K, nt), rear(K, nt);
  std::vector<double> p(ws::N_PARAMS);
  for (int k = 0; k < K; ++k) {
    for (int i = 0; i < ws::N_PARAMS; ++i) p[i] = params(k, i);
    ws::Strength s;
    s.liftoff = strength(k, 0);
    s.friction = strength(k, 1);
    s.digressive = strength(k, 2);
    s.progressive = strength(k, 3);
    bool ok = ws::simulate(p.data(), s, &t[0], nt, nsub, &front(k, 0), &rear(k, 0), K);
    if (!ok) {
      for (int j = 0; j < nt; ++j) {
        front(k, j) = NA_REAL;
        rear(k, j) = NA_REAL;
      }
    }
    if (k % 8 == 7) Rcpp::checkUserInterrupt();
  }
  return Rcpp::List::create(Rcpp::Named("site1") = front, Rcpp::Named("site2") = rear);
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
// is returned as a row of NA.
// [[Rcpp::export]]
Rcpp::List dosing_simulate_cpp(const Rcpp::NumericMatrix& params,
                               const Rcpp::NumericMatrix& strength,
                               const Rcpp::NumericVector& doses, const Rcpp::NumericVector& dose_mg,
                               const Rcpp::NumericVector& t, int nsub) {
  namespace wd = wavevalid::dosing;
  const int K = params.nrow(), nt = t.size(), nd = doses.size();
  if (params.ncol() != wd::N_PARAMS) Rcpp::stop("params must have %d columns", wd::N_PARAMS);
  if (strength.nrow() != K || strength.ncol() != 4) Rcpp::stop("strength must be K x 4");
  if (nt < 2) Rcpp::stop("t must have at least two points");
  if (nd < 1) Rcpp::stop("doses must hold at least one time");
  if (nsub < 1) Rcpp::stop("nsub must be positive");
  if (dose_mg.size() != 1 && dose_mg.size() != K) Rcpp::stop("dose_mg must hold one amount or one per run");
  Rcpp::NumericMatrix plasma(K, nt);
  std::vector<double> p(wd::N_PARAMS);
  for (int k = 0; k < K; ++k) {
    for (int i = 0; i < wd::N_PARAMS; ++i) p[i] = params(k, i);
    wd::Strength s;
    s.saturable = strength(k, 0);
    s.recycling = strength(k, 1);
    s.lag = strength(k, 2);
    s.induction = strength(k, 3);
    bool ok = wd::simulate(p.data(), s, &doses[0], nd, dose_mg[dose_mg.size() == 1 ? 0 : k], &t[0], nt, nsub, &plasma(k, 0), K);
    if (!ok) {
      for (int j = 0; j < nt; ++j) plasma(k, j) = NA_REAL;
    }
    if (k % 8 == 7) Rcpp::checkUserInterrupt();
  }
  return Rcpp::List::create(Rcpp::Named("plasma") = plasma);
}
