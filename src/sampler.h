// Modular Metropolis-Hastings sampler for the posterior of the method
// (eq. 15-19, App. C), free of R types.
//
// For each saved draw h:
//   1. sigma2_i ~ InvGamma((R - 1) / 2, rate = s2_i / 2) (or fixed values; or,
//      for a site whose noise is learned, one sigma2 for all its coefficients,
//      moved in every cycle by a random walk on log sigma2: noise_steps());
//   2. n_inner cycles of
//      (a) a joint tau2 step: each tau2_g proposed log-uniformly on
//          [tau2_g e^-0.7, tau2_g e^0.7]; Hastings factor prod tau2_new / tau2_old;
//      (b) a joint input step: each coordinate from the 50/50 mixture of
//          Uniform(support) and Uniform([x - h, x + h] cap support), with the
//          full mixture densities in the Hastings ratio;
//      target (eq. 18): prod_i N(wbar_i; m_i(z), V_i(z) + sigma2_i / R + extra_i + tau2_g(i))
//      (extra_i: a known variance of wbar_i beyond the replicates' own, 0 unless given;
//      the product over i raised to the power settings.temper, 1 unless given)
//      x prior(z) x prod_g 1 / (tau2_g + sigmabar2_g / R) (sigmabar2_g / R the
//      mean of sigma2_i / R + extra_i over the group); in the inputs' steps the
//      likelihood's ratio is raised to settings.input_weight (1 unless given: the
//      magnitude adjustment for errors the coefficients share), not in tau2's;
//   3. w^b_i from eq. (17), then w^M_i from eq. (16).
//
// prior(z): per input uniform, truncated normal or truncated log-normal (with
// the Jacobian 1 / x), times the Gaussian of each joint block (JointPrior).
//
// That is the report's sampler (proposal = REPORT). With a narrow posterior
// (many coefficients, several replicates) its joint proposals are almost never
// accepted, so the ADAPTIVE proposal replaces step 2 by
//      (a) one log-uniform step per tau2 group (same factor e^0.7 and Hastings
//          factor), using cached m, V at the current inputs;
//      (b) a Gaussian random walk on all inputs (proposals outside the support
//          have zero target density and are rejected, so the kernel stays
//          symmetric), with probability 1 - p_global, else the report's mixture
//          step with its Hastings ratio; or, when p_indep > 0, with
//          probability p_indep an independence proposal instead of the mixture
//          step: the mixture of a multivariate t (4 degrees of freedom) with
//          the mean and covariance of the second half of the burn-in and of
//          the uniform on the supports' box (sampler_walk.h), with its
//          Hastings ratio (the mixture step at p_global when the burn-in held
//          fewer than 20 p cycles).
// Before the first saved draw, `burnin` cycles (not saved) adapt the random
// walk as in Haario et al. (2001): covariance (2.38^2 / d)(Sigma_hat + eps)
// times a scale tuned by Robbins-Monro towards acceptance 0.234, starting from
// a diagonal proposal of 2% of each range and from the best (by profile
// likelihood) of n_search prior draws and the nominal start. The proposal is
// then frozen: the saved chain is a time-homogeneous Metropolis-Hastings chain.
//
// A cut (settings.informs): the coefficients of the tau2 groups marked 0 leave
// the inputs' target, so the inputs and the other groups' tau2 follow their
// posterior given the marked groups alone; each cut group's tau2 is updated
// on its own coefficients given the current inputs, and its bias drawn as in
// 3. The report's joint tau2 step then accepts the two sets of groups apart.
#ifndef WAVEVALID_SAMPLER_H
#define WAVEVALID_SAMPLER_H

#include <Eigen/Dense>
#include <vector>
#include <random>
#include <functional>
#include <cmath>
#include <limits>
#include <cstdint>
#include <stdexcept>
#include <sstream>
#include "gasp_predict.h"
#include "sampler_model.h"
#include "sampler_state.h"
#include "sampler_walk.h"

namespace wavevalid {

class Sampler : public SamplerState {
 public:
  Sampler(std::vector<SiteData> sites, std::vector<InputPrior> priors, int n_groups,
          SamplerSettings settings, std::vector<JointPrior> joints = {})
      : SamplerState(std::move(sites), std::move(priors), n_groups, std::move(settings), std::move(joints)) {}

  // progress(h) is called every report_every draws (and may throw to interrupt).
  SamplerOutput run(const std::function<void(int)>& progress) {
    const int H = set_.n_draws, S = static_cast<int>(sites_.size());
    SamplerOutput out;
    out.inputs.resize(H, p_);
    out.tau2.resize(H, G_);
    out.sigma2.resize(S); out.wb.resize(S); out.wM.resize(S);
    out.reg_shift.resize(H, K_);
    for (int s = 0; s < S; ++s) {
      const int n = sites_[s].bank->n_coef();
      out.sigma2[s].resize(H, n); out.wb[s].resize(H, n); out.wM[s].resize(H, n);
    }
    z_ = set_.z_init;
    tau2_ = Eigen::VectorXd::Zero(G_);
    sigbar_ = Eigen::VectorXd::Zero(G_);
    tau_ready_ = false;
    walk_.init(priors_);
    if (set_.resume) restore(set_.state);
    predict_all(z_, m_, v_);

    // Burn-in: blocks of n_inner cycles, sigma2 drawn at the start of each.
    if (set_.burnin > 0 && !set_.resume) {
      draw_sigma2();
      init_tau2();
      tau_ready_ = true;
      if (set_.adaptive && set_.n_search > 0) search_start();
    }
    out.z_start = z_;
    int done = 0, since_report = 0;
    while (!set_.resume && done < set_.burnin) {
      if (done > 0) draw_sigma2();
      refresh_cache();
      double ll = loglik(tau2_);
      const int len = std::min(set_.n_inner, set_.burnin - done);
      for (int it = 0; it < len; ++it) {
        ll = cycle(ll, done + it);
      }
      done += len;
      since_report += len;
      if (since_report >= 50 * set_.n_inner) { progress(0); since_report = 0; }
    }
    if (set_.adaptive && !set_.resume) walk_.freeze();
    acc_tau_ = n_tau_ = acc_input_ = n_input_ = acc_global_ = n_global_ = 0;
    acc_noise_ = n_noise_ = 0;
    out.acc_burn = acc_burn_; out.n_burn = n_burn_;

    for (int h = 0; h < H; ++h) {
      draw_sigma2();
      if (!tau_ready_) { init_tau2(); tau_ready_ = true; }
      refresh_cache();
      double ll = loglik(tau2_);
      for (int it = 0; it < set_.n_inner; ++it) ll = cycle(ll, -1);
      // the shifts given the inputs last drawn without them
      if (K_ > 0) registration_shift_step();
      out.inputs.row(h) = z_.transpose();
      out.tau2.row(h) = tau2_.transpose();
      if (K_ > 0) out.reg_shift.row(h) = a_.transpose();
      draw_coefficients(h, out);
      if ((h + 1) % set_.report_every == 0 || h + 1 == H) progress(h + 1);
    }
    out.acc_tau = acc_tau_; out.n_tau = n_tau_;
    out.acc_input = acc_input_; out.n_input = n_input_;
    out.acc_global = acc_global_; out.n_global = n_global_;
    out.acc_noise = acc_noise_; out.n_noise = n_noise_;
    out.prop_cov = set_.adaptive ? walk_.covariance() : Eigen::MatrixXd();
    save(out.end);
    return out;
  }

 private:
  bool tau_ready_ = false;

  // Where the chain stands, and back: a chain continued from its state draws
  // what the chain run at once would have drawn next.
  void save(ChainState& st) const {
    st.z = z_;
    st.tau2 = tau_ready_ ? tau2_ : Eigen::VectorXd();
    st.a = a_;
    st.eta = eta_;
    st.eta_step = eta_step_;
    walk_.save(st);
    std::ostringstream os;
    os << rng_ << ' ' << norm_;
    st.rng = os.str();
  }
  void restore(const ChainState& st) {
    if (st.z.size() != p_ || st.tau2.size() != G_ || st.a.size() != K_ ||
        st.eta.size() != eta_.size() || st.eta_step.size() != eta_step_.size())
      throw std::invalid_argument("a chain's state does not match the sampler");
    z_ = st.z;
    tau2_ = st.tau2;
    tau_ready_ = true;
    logs_valid_ = false;
    a_ = st.a;
    for (std::size_t s = 0; s < sites_.size(); ++s)
      if (sites_[s].shift_U.cols() > 0) shift_moved(static_cast<int>(s), false);
    eta_ = st.eta;
    eta_step_ = st.eta_step;
    if (set_.adaptive) walk_.restore(st);
    std::istringstream is(st.rng);
    is >> rng_ >> norm_;
    if (is.fail()) throw std::invalid_argument("a chain's state has an unreadable random number stream");
  }

  // One MH cycle; `burn_it` >= 0 is the burn-in iteration (adaptation on).
  double cycle(double ll, int burn_it) {
    if (K_ > 0 && tau_ready_) {
      registration_shift_step();
      // the inputs' target has the shifts integrated out: ll stands
      if (!collapsed()) ll = loglik(tau2_);
    }
    if (any_learn_) ll = noise_steps(burn_it >= 0);
    if (!set_.adaptive) {
      if (!set_.fix_tau2 && G_ > 0) ll = tau_step();
      return input_step(ll);
    }
    if (!set_.fix_tau2 && G_ > 0) ll = tau_steps_by_group();
    if (p_ == 0) return ll;
    const bool indep = set_.p_indep > 0.0 && walk_.has_independence();
    const double pg = indep ? set_.p_indep : set_.p_global;
    if (burn_it < 0 && pg > 0.0 && unif_(rng_) < pg) {
      const double a0 = acc_input_, n0 = n_input_;
      ll = indep ? independence_step(ll) : input_step(ll);
      acc_global_ += acc_input_ - a0;
      n_global_ += 1;
      acc_input_ = a0;
      n_input_ = n0;
      return ll;
    }
    return walk_step(ll, burn_it);
  }

  void init_tau2() {
    logs_valid_ = false;
    if (set_.fix_tau2 || set_.tau2_init.size() == G_) {
      tau2_ = set_.tau2_init;
      return;
    }
    tau2_ = moment_tau2(m_, v_);
  }

  // One random-walk step on log sigma2 per learned site; the step is tuned
  // towards acceptance 0.44 while `adapt` (the burn-in).
  double noise_steps(bool adapt) {
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      if (!d.learn_sigma2) continue;
      const double cur = eta_[s];
      const double prop = cur + eta_step_[s] * norm_(rng_);
      const double lr = noise_target(static_cast<int>(s), prop) - noise_target(static_cast<int>(s), cur);
      const bool accept = std::log(unif_(rng_)) < lr;
      if (adapt) {
        noise_adapt_n_ += 1.0;
        const double a = std::isfinite(lr) ? std::min(1.0, std::exp(std::min(lr, 0.0))) : 0.0;
        eta_step_[s] *= std::exp(std::pow(noise_adapt_n_, -0.6) * (a - 0.44));
        eta_step_[s] = std::max(1e-4, std::min(5.0, eta_step_[s]));
      } else {
        n_noise_ += 1.0;
      }
      if (!accept) continue;
      if (!adapt) acc_noise_ += 1.0;
      eta_[s] = prop;
      const double sig2 = std::exp(prop);
      sigma2_[s].setConstant(sig2);
      if (d.noise_mult.size()) sigma2_[s].array() *= d.noise_mult.array();
      for (int i = 0; i < d.bank->n_coef(); ++i) ebar_[s](i) = (sigma2_[s](i) + d.R * d.extra(i)) / d.R;
      base_[s] = v_[s] + ebar_[s];
      logs_valid_ = false;
    }
    return loglik(tau2_);
  }

  // The report's joint tau2 step. With a cut, the groups that inform the
  // inputs and those that do not are accepted or rejected each on their own
  // coefficients, so that the latter never reach the inputs.
  double tau_step() {
    Eigen::VectorXd prop(G_);
    double lr[2] = {0.0, 0.0};
    bool cut = false;
    for (int g = 0; g < G_; ++g) {
      prop(g) = tau2_(g) * std::exp(-0.7 + 1.4 * unif_(rng_));
      double& l = lr[informs_[g] ? 0 : 1];
      l += log_prior_tau(g, prop(g)) - log_prior_tau(g, tau2_(g));
      if (set_.debug_break != 2) l += std::log(prop(g) / tau2_(g));
      cut = cut || !informs_[g];
    }
    n_tau_ += 1;
    for (int part = 0; part < (cut ? 2 : 1); ++part) {
      Eigen::VectorXd next = tau2_;
      for (int g = 0; g < G_; ++g)
        if (!cut || (informs_[g] ? 0 : 1) == part) next(g) = prop(g);
      const double l = lr[part] + loglik(next, true) - loglik(tau2_, true);
      if (std::log(unif_(rng_)) < l) {
        tau2_ = next;
        logs_valid_ = false;
        acc_tau_ += cut ? 0.5 : 1.0;
      }
    }
    return loglik(tau2_);
  }

  // One log-uniform step per group; only the group's coefficients enter.
  double tau_steps_by_group() {
    for (int g = 0; g < G_; ++g) {
      if (members_[g].empty()) continue;
      const double cur = tau2_(g);
      const double prop = cur * std::exp(-0.7 + 1.4 * unif_(rng_));
      double lr = group_loglik(g, prop) - group_loglik(g, cur) + log_prior_tau(g, prop) -
                  log_prior_tau(g, cur);
      if (set_.debug_break != 2) lr += std::log(prop / cur);
      n_tau_ += 1.0 / G_;
      if (std::log(unif_(rng_)) < lr) {
        tau2_(g) = prop;
        tau2_step_taken(g, cur);
        acc_tau_ += 1.0 / G_;
      }
    }
    return loglik(tau2_);
  }

  // Log prior of input k at x alone (its support only with debug_break 3).
  double prior_term(int k, double x) const {
    return set_.debug_break == 3 ? priors_[k].log_support(x) : priors_[k].log_density(x);
  }

  // The joint Gaussian terms (0 with debug_break 3).
  double joint_terms(const Eigen::VectorXd& z) const {
    if (set_.debug_break == 3) return 0.0;
    double lp = 0.0;
    for (const JointPrior& j : joints_) lp += j.log_density(z);
    return lp;
  }

  double log_prior_inputs(const Eigen::VectorXd& z) const {
    return log_prior(priors_, joints_, z, set_.debug_break);
  }

  // An accepted proposal: the proposed inputs and their predictions become
  // the current ones (the old ones are the next proposal's buffers).
  void take_proposal() {
    z_.swap(zp_);
    m_.swap(mp_);
    v_.swap(vp_);
    refresh_cache();
    if (logs_p_valid_) {
      logs_.swap(logs_p_);
      logs_valid_ = true;
    }
    logs_p_valid_ = false;
  }

  // Adaptive Metropolis (sampler_walk.h), adapted during the burn-in.
  double walk_step(double ll_cur, int burn_it) {
    const bool adapt = burn_it >= 0;
    if (adapt) walk_.restart_at(burn_it, set_.burnin);
    walk_.propose(z_, zp_, rng_, norm_);
    double lr = -std::numeric_limits<double>::infinity();
    double ll_prop = ll_cur;
    const double lp = log_prior_inputs(zp_);
    if (std::isfinite(lp)) {
      predict_all(zp_, mp_, vp_);
      ll_prop = loglik_with(mp_, vp_, tau2_);
      lr = set_.input_weight * (ll_prop - ll_cur) + lp - log_prior_inputs(z_);
    }
    const double u = std::log(unif_(rng_));
    const bool accept = u < lr;
    if (adapt) { n_burn_ += 1; } else { n_input_ += 1; }
    if (accept) {
      take_proposal();
      if (adapt) { acc_burn_ += 1; } else { acc_input_ += 1; }
    }
    if (adapt) walk_.adapt(lr, z_);
    return accept ? ll_prop : ll_cur;
  }

  // Global move: the walk's independence proposal, accepted with the ratio
  // target(z') q(z) / (target(z) q(z')) (debug_break 1 drops q(z) / q(z')).
  double independence_step(double ll_cur) {
    walk_.propose_independent(zp_, rng_, norm_, unif_);
    double lr = -std::numeric_limits<double>::infinity();
    double ll_prop = ll_cur;
    const double lp = log_prior_inputs(zp_);
    if (std::isfinite(lp)) {
      predict_all(zp_, mp_, vp_);
      ll_prop = loglik_with(mp_, vp_, tau2_);
      lr = set_.input_weight * (ll_prop - ll_cur) + lp - log_prior_inputs(z_);
      if (set_.debug_break != 1) lr += walk_.log_independent(z_) - walk_.log_independent(zp_);
    }
    n_input_ += 1;
    if (std::log(unif_(rng_)) < lr) {
      take_proposal();
      acc_input_ += 1;
      return ll_prop;
    }
    return ll_cur;
  }

  // Moment estimates of tau2 at m, v (as init_tau2) and the log posterior
  // there: the score of a candidate start.
  double profile_score(const Eigen::VectorXd& z, Eigen::VectorXd& t2) {
    t2 = set_.fix_tau2 ? tau2_ : moment_tau2(m_, v_);
    double lp = set_.input_weight * loglik_with(m_, v_, t2) + log_prior_inputs(z);
    for (int g = 0; g < G_; ++g)
      if (informs_[g]) lp += log_prior_tau(g, t2(g));
    return lp;
  }

  // Start of the burn-in: the best of the current point and n_search prior draws.
  void search_start() {
    Eigen::VectorXd best_z = z_, t2;
    double best = profile_score(z_, t2);
    Eigen::VectorXd cand(p_);
    for (int j = 0; j < set_.n_search; ++j) {
      for (int k = 0; k < p_; ++k) cand(k) = priors_[k].draw(rng_, norm_, unif_);
      for (const JointPrior& jp : joints_) jp.draw(cand, priors_, rng_, norm_);
      predict_all(cand, m_, v_);
      const double sc = profile_score(cand, t2);
      if (sc > best) { best = sc; best_z = cand; }
      if ((j + 1) % 50 == 0) check_();
    }
    z_ = best_z;
    logs_valid_ = false;
    predict_all(z_, m_, v_);
    if (!set_.fix_tau2 && set_.tau2_init.size() != G_) tau2_ = moment_tau2(m_, v_);
  }

 public:
  std::function<void()> check_ = [] {};

 private:
  double input_step(double ll_cur) {
    if (p_ == 0) return ll_cur;
    zp_ = z_;
    double lr = 0.0;
    for (int k = 0; k < p_; ++k) {
      const InputPrior& pr = priors_[k];
      const double x = z_(k);
      const double y = pr.mixture_draw(x, half_(k), rng_, unif_);
      zp_(k) = y;
      lr += prior_term(k, y) - prior_term(k, x);
      if (set_.debug_break != 1)
        lr += std::log(pr.mixture_density(y, x, half_(k))) - std::log(pr.mixture_density(x, y, half_(k)));
    }
    if (!joints_.empty()) lr += joint_terms(zp_) - joint_terms(z_);
    predict_all(zp_, mp_, vp_);
    const double ll_prop = loglik_with(mp_, vp_, tau2_);
    lr += set_.input_weight * (ll_prop - ll_cur);
    n_input_ += 1;
    if (std::log(unif_(rng_)) < lr) {
      take_proposal();
      acc_input_ += 1;
      return ll_prop;
    }
    return ll_cur;
  }
};

}  // namespace wavevalid

#endif
