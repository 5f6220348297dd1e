// Prediction at a new input z_new from a GASP bank whose design is augmented
// by one more point z* with known outputs w* (eq. 26 of the method), without
// rebuilding the bank: with v* = L^{-1} r(z*), v = L^{-1} r(z_new),
// c = corr(z*, z_new), q = 1 - v*'v*, the augmented kriging predictor is
//   m = m0(z_new) + (c - v'v*) / q (w* - m0(z*)),
//   V = (1 - v'v - (c - v'v*)^2 / q) / lambda,
// which equals eq. 26 with the block-inverse of the augmented correlation.
#ifndef WAVEVALID_GASP_CONDITION_H
#define WAVEVALID_GASP_CONDITION_H

#include "gasp_predict.h"

namespace wavevalid {

// Correlation between two raw inputs for coefficient i.
inline double pair_corr(const GaspBank& g, int i, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  double s = 0.0;
  for (int q = 0; q < g.n_inputs(); ++q) {
    const double be = g.beta(i, q);
    if (be == 0.0) continue;
    const double d = std::abs(a(q) - b(q)) / g.width(q);
    if (d == 0.0) continue;
    s += be * std::pow(d, 2.0 - g.alpha(i, q));
  }
  return std::exp(-s);
}

// Means m and variances v (length n) at z_new given the design and (z*, w*).
inline void predict_augmented(const GaspBank& g, const Eigen::VectorXd& zstar, const Eigen::VectorXd& wstar,
                              const Eigen::VectorXd& znew, Eigen::VectorXd& m, Eigen::VectorXd& v) {
  const int n = g.n_coef();
  Eigen::MatrixXd d1s, d2s, logds, d1n, d2n, logdn;
  g.distances(zstar, d1s, d2s, logds);
  g.distances(znew, d1n, d2n, logdn);
  m.resize(n);
  v.resize(n);
  Eigen::VectorXd rs, rn;
  for (int i = 0; i < n; ++i) {
    g.corr_vector(i, d1s, d2s, logds, rs);
    g.corr_vector(i, d1n, d2n, logdn, rn);
    const double m0s = g.mu(i) + rs.dot(g.weights.col(i));
    const double m0n = g.mu(i) + rn.dot(g.weights.col(i));
    g.chol(i).triangularView<Eigen::Lower>().solveInPlace(rs);
    g.chol(i).triangularView<Eigen::Lower>().solveInPlace(rn);
    const double q = 1.0 - rs.squaredNorm();
    const double s0 = 1.0 - rn.squaredNorm();
    const double cov = pair_corr(g, i, zstar, znew) - rn.dot(rs);
    if (q > 1e-12) {
      m(i) = m0n + cov / q * (wstar(i) - m0s);
      const double var = s0 - cov * cov / q;
      v(i) = (var > 0.0 ? var : 0.0) / g.lambda(i);
    } else {
      // z* is (numerically) a design point already: nothing new to condition on
      m(i) = m0n;
      v(i) = (s0 > 0.0 ? s0 : 0.0) / g.lambda(i);
    }
  }
}

}  // namespace wavevalid

#endif
