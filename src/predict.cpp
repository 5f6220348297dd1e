// R glue for predictions in new settings.
#include <RcppEigen.h>
#include "gasp_condition.h"

namespace wavevalid {
GaspBank bank_from_list(const Rcpp::List& b);
}

// For every draw h (row): predictive mean and variance of all coefficients at
// Znew[h, ] given the design augmented with (Zstar[h, ], Wstar[h, ]).
// [[Rcpp::export]]
Rcpp::List gasp_bank_predict_augmented_cpp(const Rcpp::List& bank, const Eigen::Map<Eigen::MatrixXd>& Zstar,
                                           const Eigen::Map<Eigen::MatrixXd>& Wstar,
                                           const Eigen::Map<Eigen::MatrixXd>& Znew) {
  wavevalid::GaspBank g = wavevalid::bank_from_list(bank);
  const int H = Zstar.rows(), n = g.n_coef();
  if (Znew.rows() != H || Wstar.rows() != H) Rcpp::stop("Zstar, Wstar and Znew need one row per draw");
  if (Zstar.cols() != g.n_inputs() || Znew.cols() != g.n_inputs()) Rcpp::stop("one column per input");
  if (Wstar.cols() != n) Rcpp::stop("Wstar needs one column per coefficient");
  Eigen::MatrixXd M(H, n), V(H, n);
  Eigen::VectorXd m, v;
  for (int h = 0; h < H; ++h) {
    if (h % 32 == 0) Rcpp::checkUserInterrupt();
    wavevalid::predict_augmented(g, Zstar.row(h).transpose(), Wstar.row(h).transpose(), Znew.row(h).transpose(), m, v);
    M.row(h) = m.transpose();
    V.row(h) = v.transpose();
  }
  return Rcpp::List::create(Rcpp::Named("mean") = M, Rcpp::Named("var") = V);
}
