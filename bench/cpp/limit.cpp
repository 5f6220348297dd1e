// The machine's limit for the work of one Metropolis-Hastings cycle of the
// sampler (bench/bench_cycle.R): the same number of exp and log calls and the
// same streaming of the packed Cholesky factors (with one multiply-add per
// value, as the forward substitution does), each in a tight vectorised loop
// (the exps with the widest vectors the processor has, as the sampler's).
//
// Compiled by bench/bench_cycle.R with Rcpp::sourceCpp() and the package's
// src/ on the include path. The emulator bank's reader, bank_from_list(),
// is defined in src/gasp_predict.cpp, so that file is compiled in here too.
#include <RcppEigen.h>
#include <chrono>
#include <vector>
#include "gasp_predict.h"
#include "gasp_predict.cpp"

// [[Rcpp::depends(RcppEigen)]]

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

// Times (seconds, the fastest of `reps` repetitions) of: `n_exp` exp calls on
// arguments in [-30, 0] and `n_log` log calls on arguments in (0, 1], by
// blocks of `len` values (vectorised, as Eigen evaluates the correlation
// vectors); a pass over `n_packed` doubles laid out as `n_factors` packed
// lower triangles of order K (one multiply-add per value with a vector held
// in cache); and `n_dot` multiply-adds on data held in cache (the means).
// [[Rcpp::export]]
Rcpp::NumericVector cycle_limit_cpp(double n_exp, double n_log, int K, int n_factors, double n_dot, int len,
                                    int reps) {
  if (K < 1 || n_factors < 0 || len < 1 || reps < 1) Rcpp::stop("bad sizes");
  Eigen::ArrayXd a = Eigen::ArrayXd::LinSpaced(len, -30.0, -1e-3);
  Eigen::ArrayXd b = Eigen::ArrayXd::LinSpaced(len, 1e-6, 1.0);
  Eigen::ArrayXd out(len);
  const long ne = static_cast<long>(std::ceil(n_exp / len)), nl = static_cast<long>(std::ceil(n_log / len));
  const std::size_t stride = static_cast<std::size_t>(K) * (K + 1) / 2;
  std::vector<double> packed(stride * n_factors);
  for (std::size_t i = 0; i < packed.size(); ++i) packed[i] = 1.0 / (1.0 + (i % 97));
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(static_cast<Eigen::Index>(stride), 0.0, 1.0);
  const Eigen::VectorXd y = x.reverse();
  const long nd = static_cast<long>(std::ceil(n_dot / stride));
  double t_exp = R_PosInf, t_log = R_PosInf, t_stream = R_PosInf, t_dot = R_PosInf;
  volatile double sink = 0.0;
  for (int r = 0; r < reps; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    double acc = 0.0;
    for (long i = 0; i < ne; ++i) {
      if (wavevalid::vexp_eigen_available) {  // the sampler's exp (vexp.h)
        out = a * (1.0 + 1e-9 * i);
        wavevalid::vexp_eigen(out.data(), out.data(), len);
      } else {
        out = (a * (1.0 + 1e-9 * i)).exp();
      }
      acc += out(i % len);
    }
    t_exp = std::min(t_exp, seconds_since(t0));
    t0 = std::chrono::steady_clock::now();
    for (long i = 0; i < nl; ++i) {
      out = (b * (1.0 - 1e-9 * i)).log();
      acc += out(i % len);
    }
    t_log = std::min(t_log, seconds_since(t0));
    t0 = std::chrono::steady_clock::now();
    for (int u = 0; u < n_factors; ++u)
      acc += Eigen::Map<const Eigen::VectorXd>(packed.data() + stride * u, static_cast<Eigen::Index>(stride)).dot(x);
    t_stream = std::min(t_stream, seconds_since(t0));
    t0 = std::chrono::steady_clock::now();
    for (long i = 0; i < nd; ++i) acc += y.dot(x);
    t_dot = std::min(t_dot, seconds_since(t0));
    sink = sink + acc;
    Rcpp::checkUserInterrupt();
  }
  return Rcpp::NumericVector::create(Rcpp::Named("exp") = t_exp, Rcpp::Named("log") = t_log,
                                     Rcpp::Named("stream") = t_stream, Rcpp::Named("dot") = t_dot);
}

// Stages of the sampler's emulator predictions on one bank, each timed over
// the rows of Z (raw inputs; seconds per row, the fastest of `reps` passes):
// `distances` (|z - X| and its square and log), `means` (correlation
// vectors of the distinct correlations, then the means), `variances` (the
// forward substitutions on the packed factors); and the counts of exp
// calls, distinct correlations and packed doubles per prediction.
// [[Rcpp::export]]
Rcpp::NumericVector bank_stage_times_cpp(const Rcpp::List& bank, const Eigen::Map<Eigen::MatrixXd>& Z, int reps) {
  wavevalid::GaspBank g = wavevalid::bank_from_list(bank);
  g.pack();
  if (Z.cols() != g.n_inputs()) Rcpp::stop("Z must have one column per input");
  wavevalid::GaspBank::Workspace ws;
  g.init_workspace(ws, 1);
  const int N = Z.rows(), n = g.n_coef(), K = g.n_runs(), p = g.n_inputs();
  Eigen::VectorXd m(n), v(n), z(p);
  double t_dist = R_PosInf, t_mean = R_PosInf, t_var = R_PosInf;
  volatile double sink = 0.0;
  for (int r = 0; r < reps; ++r) {
    double td = 0, tm = 0, tv = 0;
    for (int j = 0; j < N; ++j) {
      z = Z.row(j).transpose();
      auto t0 = std::chrono::steady_clock::now();
      g.distances(z, ws.d1, ws.d2, ws.logd);
      td += seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
      g.mean_into(z, m, ws);  // computes the distances again
      tm += seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
      g.var_into(v, ws);
      tv += seconds_since(t0);
      sink = sink + m(0) + v(0);
    }
    t_dist = std::min(t_dist, td / N);
    t_mean = std::min(t_mean, (tm - td) / N);
    t_var = std::min(t_var, tv / N);
    Rcpp::checkUserInterrupt();
  }
  double n_exp = 0;
  for (int u : g.uniq) {
    n_exp += K;
    for (int q = 0; q < p; ++q) {
      const double b = g.beta(u, q), a = g.alpha(u, q);
      if (b != 0.0 && a != 0.0 && a != 1.0) n_exp += K;
    }
  }
  return Rcpp::NumericVector::create(
      Rcpp::Named("distances") = t_dist, Rcpp::Named("means") = t_mean, Rcpp::Named("variances") = t_var,
      Rcpp::Named("n_exp") = n_exp, Rcpp::Named("n_uniq") = static_cast<double>(g.uniq.size()),
      Rcpp::Named("n_packed") = static_cast<double>(g.packed.size()), Rcpp::Named("K") = K,
      Rcpp::Named("n") = n, Rcpp::Named("p") = p);
}
