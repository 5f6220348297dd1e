// R glue for the GASP bank predictor.
#include <RcppEigen.h>
#include <algorithm>
#include "gasp_predict.h"

// [[Rcpp::depends(RcppEigen)]]

namespace wavevalid {

// Builds a bank from the list kept in a wv_emulators object for one site:
// X (K x p scaled design), beta, alpha (n x p), mu, lambda (n), weights (K x n),
// chol (K x K x m array of lower Cholesky factors) with chol_of (n, the
// factor of each coefficient, from 1; without it m = n, one per
// coefficient, and equal factors are stored once), lower, width (p).
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
  const R_xlen_t KK = static_cast<R_xlen_t>(K) * K;
  std::vector<int> of(n);
  const bool indexed = b.containsElementNamed("chol_of") && !Rf_isNull(b["chol_of"]);
  R_xlen_t m = n;
  if (indexed) {
    Rcpp::IntegerVector co = b["chol_of"];
    if (co.size() != n) Rcpp::stop("emulator bank: chol_of has the wrong length");
    if (KK == 0 || ch.size() % KK != 0) Rcpp::stop("chol has the wrong size");
    m = ch.size() / KK;
    for (int i = 0; i < n; ++i) {
      if (co[i] == NA_INTEGER || co[i] < 1 || co[i] > m) Rcpp::stop("emulator bank: chol_of out of range");
      of[i] = co[i] - 1;
    }
  } else {
    if (ch.size() != KK * n) Rcpp::stop("chol has the wrong size");
    for (int i = 0; i < n; ++i) of[i] = i;
  }
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
      const double l00 = ch[static_cast<R_xlen_t>(of[i]) * KK];
      g.nugget(i) = l00 * l00 - 1.0;
    }
  }
  // each stored factor once, the first time a coefficient uses it; a factor
  // equal to one already kept (equal numbers) is not kept twice
  std::vector<int> kept(m, -1);
  g.lidx.assign(n, 0);
  const double* base = ch.begin();
  auto same = [&](R_xlen_t a, R_xlen_t c) {
    return std::equal(base + a * KK, base + (a + 1) * KK, base + c * KK);
  };
  std::vector<R_xlen_t> source;  // the slice of each kept factor
  for (int i = 0; i < n; ++i) {
    const int f = of[i];
    if (kept[f] < 0) {
      int found = -1;
      if (!indexed) {
        if (i > 0 && same(f, source[g.lidx[i - 1]])) {
          found = g.lidx[i - 1];
        } else {
          for (std::size_t u = 0; u < source.size(); ++u) {
            if (same(f, source[u])) {
              found = static_cast<int>(u);
              break;
            }
          }
        }
      }
      if (found < 0) {
        found = static_cast<int>(g.L.size());
        g.L.push_back(Eigen::Map<const Eigen::MatrixXd>(base + static_cast<R_xlen_t>(f) * KK, K, K));
        source.push_back(f);
      }
      kept[f] = found;
    }
    g.lidx[i] = kept[f];
  }
  return g;
}

// The list form of a bank (the fields bank_from_list reads).
Rcpp::List bank_to_list(const GaspBank& g) {
  const int K = g.n_runs(), n = g.n_coef();
  const R_xlen_t KK = static_cast<R_xlen_t>(K) * K;
  const int m = static_cast<int>(g.L.size());
  Rcpp::NumericVector ch(KK * m);
  for (int u = 0; u < m; ++u) std::copy(g.L[u].data(), g.L[u].data() + KK, ch.begin() + u * KK);
  ch.attr("dim") = Rcpp::IntegerVector::create(K, K, m);
  Rcpp::IntegerVector of(n);
  for (int i = 0; i < n; ++i) of[i] = g.lidx[i] + 1;
  return Rcpp::List::create(
    Rcpp::Named("X") = g.X, Rcpp::Named("beta") = g.beta, Rcpp::Named("alpha") = g.alpha,
    Rcpp::Named("mu") = g.mu, Rcpp::Named("lambda") = g.lambda, Rcpp::Named("nugget") = g.nugget,
    Rcpp::Named("weights") = g.weights, Rcpp::Named("chol") = ch, Rcpp::Named("chol_of") = of,
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
