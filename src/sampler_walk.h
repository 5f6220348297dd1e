// The adaptive random walk of the sampler's input step (sampler.h), free of
// R types: proposal z + scale * L e, e ~ N(0, I), adapted during the burn-in
// as in Haario et al. (2001) with a Robbins-Monro scale, then frozen.
// At the freeze, the mean m and covariance S of the second half of the
// burn-in also define an independence proposal for the global moves: a
// defensive mixture (Hesterberg 1995) of a multivariate t with 4 degrees of
// freedom, location m and scale matrix S (covariance 2 S), whose tails are
// heavier than a Gaussian posterior's, with weight 1 - eps, and the uniform
// on the box of the supports with weight eps = 0.2. The uniform part lets a
// chain reach regions that the burn-in did not visit (another mode) and
// bounds target / proposal.
#ifndef WAVEVALID_SAMPLER_WALK_H
#define WAVEVALID_SAMPLER_WALK_H

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>
#include "sampler_model.h"

namespace wavevalid {

class AdaptiveWalk {
 public:
  // A diagonal proposal of 2% of each input's range, nothing accumulated.
  void init(const std::vector<InputPrior>& priors) {
    p_ = static_cast<int>(priors.size());
    range_.resize(p_);
    lower_.resize(p_);
    for (int k = 0; k < p_; ++k) {
      range_(k) = priors[k].upper - priors[k].lower;
      lower_(k) = priors[k].lower;
    }
    Eigen::MatrixXd start = Eigen::MatrixXd::Zero(p_, p_);
    for (int k = 0; k < p_; ++k) start(k, k) = std::pow(0.02 * range_(k), 2);
    chol_ = start.llt().matrixL();
    acc_mean_ = Eigen::VectorXd::Zero(p_);
    acc_cov_ = Eigen::MatrixXd::Zero(p_, p_);
    acc_n_ = 0.0;
    log_scale_ = 0.0;
    adapt_n_ = 0;
    use_acc_ = false;
    has_indep_ = false;
  }

  // zp = z + scale * L e, drawing the p normals e in order.
  template <class Rng>
  void propose(const Eigen::VectorXd& z, Eigen::VectorXd& zp, Rng& rng, std::normal_distribution<double>& norm) {
    Eigen::VectorXd e(p_);
    for (int k = 0; k < p_; ++k) e(k) = norm(rng);
    zp = z + std::exp(log_scale_) * (chol_ * e);
  }

  // The running covariance is restarted at 1/4 and 1/2 of the burn-in, to
  // forget the way in from the start.
  void restart_at(int burn_it, int burnin) {
    if (burn_it == burnin / 4 || burn_it == burnin / 2) reset_moments();
  }

  // After a burn-in step with log acceptance ratio `lr`, at the chain's state
  // z: the scale follows acceptance 0.234; the proposal uses the running
  // covariance once it holds 20 p points.
  void adapt(double lr, const Eigen::VectorXd& z) {
    adapt_n_ += 1;
    const double a = std::isfinite(lr) ? std::min(1.0, std::exp(std::min(lr, 0.0))) : 0.0;
    log_scale_ += std::pow(adapt_n_, -0.6) * (a - 0.234) * 2.0;
    log_scale_ = std::max(-15.0, std::min(5.0, log_scale_));
    accumulate(z);
    if (acc_n_ >= 20.0 * p_) {
      if (!use_acc_) { use_acc_ = true; log_scale_ = 0.0; adapt_n_ = 1; }
      if (static_cast<int>(acc_n_) % 10 == 0) set_from_accumulator();
    }
  }

  // At the end of the burn-in: scale folded into the covariance, no more
  // changes; the independence proposal from the accumulated moments when
  // they hold at least 20 p points.
  void freeze() {
    const double sc = std::exp(log_scale_);
    chol_ *= sc;
    log_scale_ = 0.0;
    has_indep_ = false;
    if (acc_n_ >= 20.0 * p_ && p_ > 0) set_independence(acc_mean_, accumulated_covariance());
  }

  // A frozen walk learned anew from a chain's draws (rows of Z, at least
  // 20 p of them), their moments accumulated as the burn-in accumulates its
  // own: the walk 2.38^2 / p times their covariance, and, where the walk has
  // an independence proposal, that proposal their mean and covariance. False,
  // and the walk unchanged, when the covariance is not positive definite.
  bool learn_from_draws(const Eigen::MatrixXd& Z) {
    if (Z.cols() != p_ || Z.rows() < 20 * p_ || p_ == 0)
      throw std::invalid_argument("the draws must have one column per input and at least 20 rows per input");
    reset_moments();
    for (Eigen::Index r = 0; r < Z.rows(); ++r) accumulate(Z.row(r).transpose());
    if (!set_from_accumulator()) return false;
    log_scale_ = 0.0;
    if (has_indep_) set_independence(acc_mean_, accumulated_covariance());
    return true;
  }

  bool has_independence() const { return has_indep_; }

  // A draw of the independence proposal: with probability eps a uniform
  // point of the box (p uniforms), else m + L e sqrt(nu / w), e ~ N(0, I),
  // w ~ chi-square(nu) as a sum of nu squared normals (p + nu normals in order).
  template <class Rng>
  void propose_independent(Eigen::VectorXd& zp, Rng& rng, std::normal_distribution<double>& norm,
                           std::uniform_real_distribution<double>& unif) const {
    zp.resize(p_);
    if (unif(rng) < kEps) {
      for (int k = 0; k < p_; ++k) zp(k) = lower_(k) + range_(k) * unif(rng);
      return;
    }
    Eigen::VectorXd e(p_);
    for (int k = 0; k < p_; ++k) e(k) = norm(rng);
    double w = 0.0;
    for (int k = 0; k < kNu; ++k) { const double g = norm(rng); w += g * g; }
    zp = ind_mean_ + std::sqrt(kNu / w) * (ind_chol_ * e);
  }

  // Log density of the independence proposal at z (a point of the box).
  double log_independent(const Eigen::VectorXd& z) const {
    const Eigen::VectorXd u = ind_chol_.triangularView<Eigen::Lower>().solve(z - ind_mean_);
    const double lt = std::log1p(-kEps) + log_t_const_ - 0.5 * (kNu + p_) * std::log1p(u.squaredNorm() / kNu);
    const double lu = std::log(kEps) + log_box_;
    const double hi = std::max(lt, lu);
    return hi + std::log(std::exp(lt - hi) + std::exp(lu - hi));
  }

  Eigen::MatrixXd covariance() const { return chol_ * chol_.transpose(); }

  // The frozen walk, kept in and taken from a chain's state.
  void save(ChainState& st) const {
    st.walk_chol = std::exp(log_scale_) * chol_;
    st.has_indep = has_indep_;
    st.ind_chol = ind_chol_;
    st.ind_mean = ind_mean_;
    st.log_t_const = log_t_const_;
    st.log_box = log_box_;
  }
  void restore(const ChainState& st) {
    if (st.walk_chol.rows() != p_ || st.walk_chol.cols() != p_)
      throw std::invalid_argument("a chain's state has a walk of the wrong size");
    chol_ = st.walk_chol;
    log_scale_ = 0.0;
    has_indep_ = st.has_indep;
    ind_chol_ = st.ind_chol;
    ind_mean_ = st.ind_mean;
    log_t_const_ = st.log_t_const;
    log_box_ = st.log_box;
  }

 private:
  int p_ = 0;
  Eigen::MatrixXd chol_, acc_cov_;
  Eigen::VectorXd acc_mean_, range_;
  double log_scale_ = 0.0, acc_n_ = 0.0;
  int adapt_n_ = 0;
  bool use_acc_ = false;
  static constexpr int kNu = 4;
  // the walk's size, 2.38^2 / p times the covariance (Gelman, Roberts and Gilks 1996)
  static constexpr double kWalk = 2.38 * 2.38;
  static constexpr double kEps = 0.2;
  Eigen::VectorXd lower_;
  double log_t_const_ = 0.0, log_box_ = 0.0;
  Eigen::MatrixXd ind_chol_;
  Eigen::VectorXd ind_mean_;
  bool has_indep_ = false;

  void accumulate(const Eigen::VectorXd& z) {
    acc_n_ += 1.0;
    const Eigen::VectorXd d = z - acc_mean_;
    acc_mean_ += d / acc_n_;
    acc_cov_ += d * (z - acc_mean_).transpose();
  }

  // The running covariance, with a jitter of 1e-6 of each input's range
  // squared on the diagonal.
  Eigen::MatrixXd accumulated_covariance() const {
    Eigen::MatrixXd C = acc_cov_ / std::max(acc_n_ - 1.0, 1.0);
    jitter(C);
    return C;
  }

  void jitter(Eigen::MatrixXd& C) const {
    for (int k = 0; k < p_; ++k) C(k, k) += 1e-6 * range_(k) * range_(k);
  }

  // Proposal covariance from the running covariance of the chain; false, and
  // the walk unchanged, when it is not positive definite.
  bool set_from_accumulator() {
    Eigen::MatrixXd C = accumulated_covariance();
    C *= kWalk / p_;
    Eigen::LLT<Eigen::MatrixXd> llt(C);
    if (llt.info() != Eigen::Success) return false;
    chol_ = llt.matrixL();
    return true;
  }

  void reset_moments() {
    acc_n_ = 0.0;
    acc_mean_.setZero();
    acc_cov_.setZero();
  }

  // The independence proposal's t with location m and scale matrix C; left
  // off when C is not positive definite.
  void set_independence(const Eigen::VectorXd& m, const Eigen::MatrixXd& C) {
    has_indep_ = false;
    Eigen::LLT<Eigen::MatrixXd> llt(C);
    if (llt.info() != Eigen::Success) return;
    ind_chol_ = llt.matrixL();
    ind_mean_ = m;
    // log normalising constants of the t density and of the uniform on the box
    double logdet = 0.0;
    for (int k = 0; k < p_; ++k) logdet += std::log(ind_chol_(k, k));
    log_t_const_ = std::lgamma(0.5 * (kNu + p_)) - std::lgamma(0.5 * kNu) -
                   0.5 * p_ * std::log(kNu * M_PI) - logdet;
    log_box_ = -range_.array().log().sum();
    has_indep_ = true;
  }
};

}  // namespace wavevalid

#endif
