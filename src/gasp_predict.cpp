// R glue for the GASP bank predictor.
#include <RcppEigen.h>
#include "gasp_predict.h"

// [[Rcpp::depends(RcppEigen)]]

namespace wavevalid {

// Builds a bank from the list kept in a wv_emulators object for one site:
// X (K x p scaled design), beta, alpha (n x p), mu, lambda (n), weights (K x n),
// chol (K x K x n array of lower Cholesky factors), lower, width (p).
GaspBank bank_from_list(const Rcpp::List& b) {
  GaspBank g;
  g.X = Rcpp::as<Eigen::MatrixXd>(b["X"]);
  g.beta = Rcpp::as<Eigen::MatrixXd>(b["beta"]);
  g.alpha = Rcpp::as<Eigen::MatrixXd>(b["alpha"]);
  g.mu = Rcpp::as<Eigen::VectorXd>(b["mu"]);
  g.lambda = Rcpp::as<Eigen::VectorXd>(b["lambda"]);
  g.weights = Rcpp::as<Eigen::MatrixXd>(b["weights"]);
  g.lower = Rcpp::as<Eigen::VectorXd>(b["lower"]);
  g.width = Rcpp::as<Eigen::VectorXd>(b["width"]);
  Rcpp::NumericVector ch = b["chol"];
  const int K = g.X.rows(), n = g.mu.size();
  if (ch.size() != static_cast<R_xlen_t>(K) * K * n) Rcpp::stop("chol has the wrong size");
  if (g.beta.rows() != n || g.alpha.rows() != n || g.weights.cols() != n || g.lambda.size() != n)
    Rcpp::stop("emulator bank: inconsistent number of coefficients");
  if (g.beta.cols() != g.X.cols() || g.alpha.cols() != g.X.cols() || g.weights.rows() != K)
    Rcpp::stop("emulator bank: inconsistent dimensions");
  if (b.containsElementNamed("nugget")) {
    g.nugget = Rcpp::as<Eigen::VectorXd>(b["nugget"]);
    if (g.nugget.size() != n) Rcpp::stop("emulator bank: nugget has the wrong length");
  } else {
    g.nugget.resize(n);
    for (int i = 0; i < n; ++i) {
      const double l00 = ch[static_cast<R_xlen_t>(i) * K * K];
      g.nugget(i) = l00 * l00 - 1.0;
    }
  }
  g.L.resize(n);
  for (int i = 0; i < n; ++i) {
    g.L[i] = Eigen::Map<const Eigen::MatrixXd>(&ch[static_cast<R_xlen_t>(i) * K * K], K, K);
  }
  return g;
}

// The list form of a bank (the fields bank_from_list reads).
Rcpp::List bank_to_list(const GaspBank& g) {
  const int K = g.n_runs(), n = g.n_coef();
  Rcpp::NumericVector ch(static_cast<R_xlen_t>(K) * K * n);
  for (int i = 0; i < n; ++i) {
    std::copy(g.L[i].data(), g.L[i].data() + K * K, ch.begin() + static_cast<R_xlen_t>(i) * K * K);
  }
  ch.attr("dim") = Rcpp::IntegerVector::create(K, K, n);
  return Rcpp::List::create(
    Rcpp::Named("X") = g.X, Rcpp::Named("beta") = g.beta, Rcpp::Named("alpha") = g.alpha,
    Rcpp::Named("mu") = g.mu, Rcpp::Named("lambda") = g.lambda, Rcpp::Named("nugget") = g.nugget,
    Rcpp::Named("weights") = g.weights, Rcpp::Named("chol") = ch,
    Rcpp::Named("lower") = g.lower, Rcpp::Named("width") = g.width);
}

}  // namespace wavevalid

// Bank augmented by one design point z (raw units) with coefficient values w
// (eq. 26): hyperparameters fixed, Cholesky factors extended by one row.
// [[Rcpp::export]]
Rcpp::List gasp_bank_augment_cpp(const Rcpp::List& bank, const Eigen::Map<Eigen::VectorXd>& z,
                                 const Eigen::Map<Eigen::VectorXd>& w) {
  wavevalid::GaspBank g = wavevalid::bank_from_list(bank);
  if (z.size() != g.n_inputs()) Rcpp::stop("z must have one value per input");
  if (w.size() != g.n_coef()) Rcpp::stop("w must have one value per coefficient");
  return wavevalid::bank_to_list(g.augment(z, w));
}

// Predictive means and variances of every coefficient at each row of Z.
// [[Rcpp::export]]
Rcpp::List gasp_bank_predict_cpp(const Rcpp::List& bank, const Eigen::Map<Eigen::MatrixXd>& Z) {
  wavevalid::GaspBank g = wavevalid::bank_from_list(bank);
  g.find_shared();
  const int N = Z.rows(), n = g.n_coef();
  if (Z.cols() != g.n_inputs()) Rcpp::stop("Z must have one column per input");
  Eigen::MatrixXd M(N, n), V(N, n);
  Eigen::VectorXd m, v;
  for (int j = 0; j < N; ++j) {
    if (j % 64 == 0) Rcpp::checkUserInterrupt();
    g.predict(Z.row(j).transpose(), m, v, true);
    M.row(j) = m.transpose();
    V.row(j) = v.transpose();
  }
  return Rcpp::List::create(Rcpp::Named("mean") = M, Rcpp::Named("var") = V);
}
