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
  g.L.resize(n);
  for (int i = 0; i < n; ++i) {
    g.L[i] = Eigen::Map<const Eigen::MatrixXd>(&ch[static_cast<R_xlen_t>(i) * K * K], K, K);
  }
  return g;
}

}  // namespace wavevalid

// Predictive means and variances of every coefficient at each row of Z.
// [[Rcpp::export]]
Rcpp::List gasp_bank_predict_cpp(const Rcpp::List& bank, const Eigen::Map<Eigen::MatrixXd>& Z) {
  wavevalid::GaspBank g = wavevalid::bank_from_list(bank);
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
