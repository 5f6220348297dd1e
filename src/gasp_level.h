// Shared correlation parameters for the m coefficients of one wavelet level:
// every coefficient y_i (a column of Y, K x m) has its own mean mu_i and
// variance 1 / lambda_i, all share the power-exponential correlation R(theta),
// theta = (log beta_1..p, alpha_1..p). The objective is the sum of the
// coefficients' profile log-likelihoods (gasp_lik.h) plus the log of a
// jointly robust prior on the inverse ranges,
//   l(theta) = sum_i [-K/2 log(2 pi s2_i) - 1/2 log|R| - K/2] + log pi(theta),
// with one Cholesky factor of R per evaluation. Optionally (restricted = 1)
// each mu_i is integrated out instead of profiled (the restricted likelihood,
// as in the marginal posterior of a GASP with a flat prior on mu):
//   l_i = -(K-1)/2 log(2 pi s2_i) - 1/2 log|R| - 1/2 log(1'R^-1 1) - (K-1)/2,
// s2_i = (y_i - mu_i)'R^-1(y_i - mu_i) / (K - 1).
// Gradient: with u_i = R^-1 (y_i - mu_i), a = R^-1 1,
//   dl/dtheta = 1/2 tr[(sum_i u_i u_i' / s2_i - m R^-1 + r m a a' / 1'a) dR/dtheta]
//               + dlog pi / dtheta   (r = restricted).
// Jointly robust prior (Gu 2019), on rho_q = beta_q^(1 / (2 - alpha_q)), the
// inverse range of input q on the unit cube (beta d^(2 - alpha) = (rho d)^(2 - alpha)):
//   log pi = a log(C sum_q rho_q) - b C sum_q rho_q,
//   C = K^(-1/p), a = 0.2, b = K^(-1/p) (a + p),
// added once per level. Free of R types.
#ifndef WAVEVALID_GASP_LEVEL_H
#define WAVEVALID_GASP_LEVEL_H

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include "gasp_lik.h"

namespace wavevalid {

struct GaspLevelPrior {
  int type = 1;        // 0: none, 1: jointly robust
  double a = 0.2;      // jointly robust prior's exponent
  double b_mult = 1.0; // multiplies the rate b = K^(-1/p) (a + p)
};

class GaspLevelLik {
 public:
  GaspLevelLik(const GaspDist& D, const Eigen::MatrixXd& Y, const GaspLevelPrior& prior, int restricted)
      : D_(D), Y_(Y), prior_(prior), restricted_(restricted != 0) {
    K_ = D.K;
    p_ = D.p;
    P_ = D.P;
    m_ = static_cast<int>(Y.cols());
    T_.resize(P_, p_);
    S_.resize(P_);
    R_.resize(K_, K_);
    Ri_.resize(K_, K_);
    inverse_.resize(K_);
    Mp_.resize(P_);
    ones_ = Eigen::VectorXd::Ones(K_);
    C_jr_ = std::pow(static_cast<double>(K_), -1.0 / p_);
    b_jr_ = prior_.b_mult * C_jr_ * (prior_.a + p_);
  }

  int n_runs() const { return K_; }
  int n_inputs() const { return p_; }
  int n_coef() const { return m_; }
  const GaspDist& dist() const { return D_; }
  int n_eval = 0, n_grad = 0;

  void build(const Eigen::VectorXd& theta, double nugget) { build_correlation(D_, theta, nugget, T_, S_, C_, R_); }

  // log of the prior on theta, and its gradient when g is given.
  double log_prior(const Eigen::VectorXd& theta, Eigen::VectorXd* g) const {
    if (g) g->setZero(2 * p_);
    if (prior_.type == 0) return 0.0;
    double t = 0.0;
    Eigen::VectorXd rho(p_);
    for (int q = 0; q < p_; ++q) {
      rho(q) = std::exp(theta(q) / (2.0 - theta(p_ + q)));
      t += rho(q);
    }
    t *= C_jr_;
    const double lp = prior_.a * std::log(t) - b_jr_ * t;
    if (g) {
      const double dt = (prior_.a / t - b_jr_) * C_jr_;  // d log pi / d rho_q
      for (int q = 0; q < p_; ++q) {
        const double e = 2.0 - theta(p_ + q);
        (*g)(q) = dt * rho(q) / e;
        (*g)(p_ + q) = dt * rho(q) * theta(q) / (e * e);
      }
    }
    return lp;
  }

  // Objective at theta; -inf when R is numerically singular.
  double value(const Eigen::VectorXd& theta, double nugget, double rcond_fail) {
    ++n_eval;
    theta_ = theta;
    build(theta, nugget);
    llt_.compute(R_);
    if (llt_.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
    rcond_ = llt_.rcond();
    if (!(rcond_ >= rcond_fail)) return -std::numeric_limits<double>::infinity();
    a_ = llt_.solve(ones_);
    const Eigen::MatrixXd B = llt_.solve(Y_);
    one_a_ = ones_.dot(a_);
    mu_ = (ones_.transpose() * B).transpose() / one_a_;
    U_ = B - a_ * mu_.transpose();  // R^-1 (y_i - mu_i)
    const double dof = restricted_ ? K_ - 1.0 : static_cast<double>(K_);
    s2_.resize(m_);
    for (int i = 0; i < m_; ++i) {
      s2_(i) = (Y_.col(i).array() - mu_(i)).matrix().dot(U_.col(i)) / dof;
      if (!(s2_(i) > 0.0) || !std::isfinite(s2_(i))) return -std::numeric_limits<double>::infinity();
    }
    const Eigen::MatrixXd& L = llt_.matrixLLT();
    double logdet = 0.0;
    for (int k = 0; k < K_; ++k) logdet += std::log(L(k, k));
    logdet *= 2.0;
    double ll = -0.5 * dof * (2.0 * M_PI * s2_.array()).log().sum() - 0.5 * m_ * logdet - 0.5 * dof * m_;
    if (restricted_) ll -= 0.5 * m_ * std::log(one_a_);
    return ll + log_prior(theta, nullptr);
  }

  // Gradient at the point of the last successful value().
  void gradient(Eigen::VectorXd& grad) {
    ++n_grad;
    grad.resize(2 * p_);
    const Eigen::MatrixXd& L = llt_.matrixLLT();
    inverse_.compute(L, Ri_);
    // G = sum_i u_i u_i' / s2_i - m R^-1 (+ m a a' / 1'a), lower triangle
    const Eigen::MatrixXd Us = U_ * s2_.cwiseInverse().cwiseSqrt().asDiagonal();
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(K_, K_);
    G.selfadjointView<Eigen::Lower>().rankUpdate(Us);
    G -= m_ * Ri_;
    if (restricted_) G += (m_ / one_a_) * (a_ * a_.transpose());
    int idx = 0;
    for (int k = 0; k < K_; ++k) {
      for (int j = k + 1; j < K_; ++j) {
        Mp_(idx) = G(j, k) * C_(idx);
        ++idx;
      }
    }
    for (int q = 0; q < p_; ++q) {
      const Eigen::ArrayXd mt = Mp_ * T_.col(q).array();
      grad(q) = -mt.sum();
      grad(p_ + q) = (mt * D_.logd.col(q).array().max(-745.0)).sum();
    }
    Eigen::VectorXd gp;
    log_prior(theta_, &gp);
    grad += gp;
  }

  double eval(const Eigen::VectorXd& theta, double nugget, Eigen::VectorXd* grad, double rcond_fail) {
    const double ll = value(theta, nugget, rcond_fail);
    if (grad && std::isfinite(ll)) gradient(*grad);
    return ll;
  }

  const Eigen::VectorXd& mu() const { return mu_; }
  const Eigen::VectorXd& sigma2() const { return s2_; }
  double rcond() const { return rcond_; }

 private:
  const GaspDist& D_;
  Eigen::MatrixXd Y_;
  GaspLevelPrior prior_;
  bool restricted_;
  int K_, p_, P_, m_;
  double C_jr_ = 1.0, b_jr_ = 1.0, one_a_ = 1.0;
  Eigen::MatrixXd T_, R_, Ri_, U_;
  InverseGram inverse_;
  Eigen::ArrayXd S_, C_, Mp_;
  Eigen::VectorXd ones_, a_, mu_, s2_, theta_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  double rcond_ = 0.0;
};

}  // namespace wavevalid

#endif
