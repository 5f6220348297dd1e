// The state of the modular Metropolis-Hastings sampler (sampler.h): data,
// priors, settings, the emulator predictions and variances cached at the
// current inputs, and what every step needs of them: the likelihood of the
// field means (on its own per coefficient, or jointly over the experiments
// sharing a bias), the tau2 priors, the noise target, and the draw of the
// bias and model coefficients. Free of R types.
#ifndef WAVEVALID_SAMPLER_STATE_H
#define WAVEVALID_SAMPLER_STATE_H

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>
#include "gasp_predict.h"
#include "sampler_model.h"
#include "sampler_team.h"
#include "sampler_walk.h"

namespace wavevalid {

class SamplerState {
 public:
  SamplerState(std::vector<SiteData> sites, std::vector<InputPrior> priors, int n_groups,
          SamplerSettings settings, std::vector<JointPrior> joints = {})
      : sites_(std::move(sites)), priors_(std::move(priors)), joints_(std::move(joints)), G_(n_groups),
        set_(settings) {
    p_ = static_cast<int>(priors_.size());
    const std::size_t S = sites_.size();
    m_.resize(S); v_.resize(S); mp_.resize(S); vp_.resize(S); ws_.resize(S);
    sigma2_.resize(S); ebar_.resize(S); base_.resize(S); resid2_.resize(S);
    group_site_.assign(G_, -1);
    group_count_.assign(G_, 0);
    spans_.assign(G_, 0);
    for (std::size_t s = 0; s < S; ++s) {
      const int n = sites_[s].bank->n_coef();
      m_[s].resize(n); v_[s].resize(n); mp_[s].resize(n); vp_[s].resize(n);
      sigma2_[s].resize(n); ebar_[s].resize(n); base_[s].resize(n); resid2_[s].resize(n);
      if (!sites_[s].bank->is_packed())
        throw std::invalid_argument("emulator bank not packed");
      sites_[s].bank->init_workspace(ws_[s], set_.threads);
      for (int i = 0; i < n; ++i) {
        const int g = sites_[s].group[i];
        if (group_site_[g] >= 0 && group_site_[g] != static_cast<int>(s)) spans_[g] = 1;
        group_site_[g] = static_cast<int>(s);
        group_count_[g] += 1;
      }
      if (sites_[s].shift.size() > 0 && sites_[s].shift.size() != static_cast<Eigen::Index>(priors_.size()))
        throw std::invalid_argument("a site's input shift has the wrong length");
    }
    zs_.resize(S);
    for (std::size_t s = 0; s < S; ++s) {
      bool placed = false;
      for (std::vector<int>& grp : bank_groups_) {
        if (sites_[grp[0]].bank == sites_[s].bank) {
          grp.push_back(static_cast<int>(s));
          placed = true;
          break;
        }
      }
      if (!placed) bank_groups_.push_back({static_cast<int>(s)});
    }
    resid_.resize(S);
    dependents_.assign(S, std::vector<int>());
    for (std::size_t s = 0; s < S; ++s) {
      const int r = sites_[s].bias_of;
      if (r < 0) continue;
      if (r >= static_cast<int>(S) || sites_[r].bias_of >= 0 || sites_[r].bank->n_coef() != sites_[s].bank->n_coef())
        throw std::invalid_argument("a site shares the bias of a site it cannot");
      for (int i = 0; i < sites_[s].bank->n_coef(); ++i)
        if (sites_[s].group[i] != sites_[r].group[i])
          throw std::invalid_argument("sites sharing a bias must share its variances");
      dependents_[r].push_back(static_cast<int>(s));
      shared_ = true;
    }
    K_ = static_cast<int>(set_.reg_shift_var.size());
    a_ = Eigen::VectorXd::Zero(K_);
    for (std::size_t s = 0; s < S; ++s) {
      SiteData& d = sites_[s];
      d.wbar0 = d.wbar;
      if (d.shift_U.cols() == 0) continue;
      if (d.shift_U.cols() != K_ || d.shift_U.rows() != d.bank->n_coef())
        throw std::invalid_argument("a site's registration shifts have the wrong size");
    }
    shift_rows_.assign(S, std::vector<int>());
    shift_Ur_.assign(S, std::vector<double>());
    for (std::size_t s = 0; s < S; ++s) {
      const SiteData& d = sites_[s];
      for (int i = 0; i < d.shift_U.rows() && d.shift_U.cols() > 0; ++i) {
        if (!(d.shift_U.row(i).array() != 0.0).any()) continue;
        shift_rows_[s].push_back(i);
        for (int k = 0; k < K_; ++k) shift_Ur_[s].push_back(d.shift_U(i, k));
      }
    }
    shift_P_.resize(K_, K_);
    shift_b_.resize(K_);
    if (K_ > 0 && (shared_ || !(set_.reg_shift_var.array() > 0.0).all()))
      throw std::invalid_argument("registration shifts need positive variances and no shared bias");
    eta_.assign(S, 0.0);
    eta_step_.assign(S, 0.5);
    for (std::size_t s = 0; s < S; ++s) {
      if (!sites_[s].learn_sigma2) continue;
      any_learn_ = true;
      eta_[s] = 2.0 * std::log(sites_[s].noise_scale);
      eta_step_[s] = std::min(1.0, 2.4 * std::sqrt(2.0 / std::max(1, sites_[s].bank->n_coef())));
    }
    members_.assign(G_, std::vector<int>());
    msite_.assign(G_, std::vector<int>());
    for (std::size_t s = 0; s < S; ++s)
      for (int i = 0; i < sites_[s].bank->n_coef(); ++i) {
        members_[sites_[s].group[i]].push_back(i);
        msite_[sites_[s].group[i]].push_back(static_cast<int>(s));
      }
    informs_.assign(G_, 1);
    if (!set_.informs.empty()) {
      if (static_cast<int>(set_.informs.size()) != G_) throw std::invalid_argument("informs has the wrong length");
      for (int g = 0; g < G_; ++g) informs_[g] = set_.informs[g] != 0;
    }
    log_cache_ = !shared_ && set_.debug_break != 5 && set_.debug_break != 9 &&
                 std::all_of(informs_.begin(), informs_.end(), [](char c) { return c != 0; });
    logs_.resize(S);
    logs_p_.resize(S);
    for (std::size_t s = 0; s < S; ++s) {
      logs_[s].resize(sites_[s].bank->n_coef());
      logs_p_[s].resize(sites_[s].bank->n_coef());
    }
    std::size_t widest = 0;
    for (const std::vector<int>& mem : members_) widest = std::max(widest, mem.size());
    glogs_.resize(static_cast<Eigen::Index>(widest));
    half_.resize(p_);
    for (int k = 0; k < p_; ++k) half_(k) = set_.step * (priors_[k].upper - priors_[k].lower);
    std::seed_seq sq{static_cast<std::uint32_t>(set_.seed & 0xffffffffu),
                     static_cast<std::uint32_t>(set_.seed >> 32),
                     static_cast<std::uint32_t>(set_.chain), 0x9e3779b9u};
    rng_.seed(sq);
  }

 protected:
  std::vector<SiteData> sites_;
  std::vector<InputPrior> priors_;
  std::vector<JointPrior> joints_;
  int G_, p_ = 0;
  SamplerSettings set_;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> unif_{0.0, 1.0};
  std::normal_distribution<double> norm_{0.0, 1.0};

  Eigen::VectorXd z_, zp_, half_, tau2_, sigbar_;
  std::vector<Eigen::VectorXd> m_, v_, mp_, vp_, sigma2_, ebar_, base_, resid2_;
  std::vector<GaspBank::Workspace> ws_;
  std::vector<int> group_site_, group_count_;
  std::vector<char> informs_;  // per tau2 group: do its coefficients enter the inputs' target?
  double acc_tau_ = 0, n_tau_ = 0, acc_input_ = 0, n_input_ = 0;
  double acc_global_ = 0, n_global_ = 0, acc_burn_ = 0, n_burn_ = 0;
  std::vector<std::vector<int>> members_;  // coefficients of each tau2 group
  std::vector<std::vector<int>> msite_;    // their sites
  std::vector<char> spans_;                // 1: the group's coefficients are in several sites
  std::vector<Eigen::VectorXd> zs_;        // inputs shifted by a site's change
  std::vector<Eigen::VectorXd> resid_;     // wbar - m at the current inputs (with a shared bias)
  std::vector<std::vector<int>> dependents_;  // the sites sharing each site's bias
  bool shared_ = false;                     // some sites share a bias
  int K_ = 0;                               // the registration's shifts
  Eigen::VectorXd a_;                       // their current values
  // By site, the coefficients that a shift moves (the rows of shift_U with a
  // nonzero entry; a shift moves the curve near its landmark only, so most
  // rows are zero) and those rows of shift_U, K values each, one after the
  // other; the shifts' precision and its right-hand side (scratch).
  std::vector<std::vector<int>> shift_rows_;
  std::vector<std::vector<double>> shift_Ur_;
  mutable Eigen::MatrixXd shift_P_;
  mutable Eigen::VectorXd shift_b_;

  // log(V + sigma2 / R + extra + tau2) of every coefficient at the current
  // inputs and tau2 (logs_, when logs_valid_) and at the last proposed
  // inputs (logs_p_, when logs_p_valid_), and of one group's coefficients at
  // its proposed tau2 (glogs_): each log is taken once and read by every step
  // that needs it, the same number as taken again, so the same draws. Kept
  // where every coefficient enters the inputs' target on its own (no cut, no
  // shared bias: log_cache_).
  bool log_cache_ = false;
  mutable std::vector<Eigen::VectorXd> logs_, logs_p_;
  mutable bool logs_valid_ = false, logs_p_valid_ = false;
  mutable Eigen::VectorXd glogs_;
  void shift_start() const;
  void shift_add(int s, int r, double w, double y) const;
  void shift_moved(int s, bool resid);

  // The registration's shifts (sampler_shifts.h): their Gibbs step, and the
  // inputs' target with them integrated out (debug_break 8: given them).
  void registration_shift_step();
  double collapsed_loglik(const std::vector<Eigen::VectorXd>& m, const std::vector<Eigen::VectorXd>& v,
                          const Eigen::VectorXd& tau2, const std::vector<Eigen::VectorXd>* logs_in = nullptr,
                          std::vector<Eigen::VectorXd>* logs_out = nullptr) const;
  bool collapsed() const { return K_ > 0 && set_.debug_break != 8; }

  AdaptiveWalk walk_;  // the random walk of the adaptive input step

  // Learned noise: log sigma2 of each site (used where learn_sigma2), the
  // random-walk step on it (tuned during the burn-in), acceptance counts.
  std::vector<double> eta_, eta_step_;
  bool any_learn_ = false;
  double acc_noise_ = 0, n_noise_ = 0, noise_adapt_n_ = 0;

  // The emulators' means and variances at every site at inputs z (each site
  // at z plus its shift). The sites that share a bank (an experiment's site
  // and the base site at the same gauge) are predicted together
  // (predict_many()), the same numbers as one by one.
  void predict_all(const Eigen::VectorXd& z, std::vector<Eigen::VectorXd>& m,
                   std::vector<Eigen::VectorXd>& v) {
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      if (sites_[s].shift.size() > 0) zs_[s] = z + sites_[s].shift;
    }
    if (team_) {
      team_z_ = &z;
      team_m_ = &m;
      team_v_ = &v;
      team_->predict(team_chain_);
      return;
    }
    for (const std::vector<int>& grp : bank_groups_) {
      if (grp.size() == 1) {
        const int s = grp[0];
        sites_[s].bank->predict_into(sites_[s].shift.size() ? zs_[s] : z, m[s], v[s], ws_[s], true);
        continue;
      }
      group_z_.clear();
      group_m_.clear();
      group_v_.clear();
      group_ws_.clear();
      for (int s : grp) {
        group_z_.push_back(sites_[s].shift.size() ? &zs_[s] : &z);
        group_m_.push_back(&m[s]);
        group_v_.push_back(&v[s]);
        group_ws_.push_back(&ws_[s]);
      }
      sites_[grp[0]].bank->predict_many(group_z_, group_m_, group_v_, group_ws_);
    }
  }

  // A chain of a team (sampler_team.h): its predictions are made in step
  // with the other chains'; team_group() gives the team the pending
  // request's sites of one bank group.
  PredictTeam* team_ = nullptr;
  int team_chain_ = 0;
  const Eigen::VectorXd* team_z_ = nullptr;
  std::vector<Eigen::VectorXd>* team_m_ = nullptr;
  std::vector<Eigen::VectorXd>* team_v_ = nullptr;

 public:
  void join_team(PredictTeam* team, int chain) {
    team_ = team;
    team_chain_ = chain;
  }
  int n_bank_groups() const { return static_cast<int>(bank_groups_.size()); }
  void team_group(int g, BankCall& call) {
    const std::vector<int>& grp = bank_groups_[g];
    call.bank = sites_[grp[0]].bank;
    for (int s : grp) {
      call.z.push_back(sites_[s].shift.size() ? &zs_[s] : team_z_);
      call.m.push_back(&(*team_m_)[s]);
      call.v.push_back(&(*team_v_)[s]);
      call.ws.push_back(&ws_[s]);
    }
  }

 protected:
  // The sites grouped by the emulator bank they evaluate, in order of first
  // appearance.
  std::vector<std::vector<int>> bank_groups_;
  // predict_all()'s pointers to one group's inputs, outputs and workspaces,
  // kept between cycles so that a cycle allocates nothing
  std::vector<const Eigen::VectorXd*> group_z_;
  std::vector<Eigen::VectorXd*> group_m_, group_v_;
  std::vector<GaspBank::Workspace*> group_ws_;

  void draw_sigma2() {
    logs_valid_ = false;
    sigbar_.setZero();
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      const int n = d.bank->n_coef();
      if (d.fixed_sigma2) {
        sigma2_[s] = d.sigma2_fixed;
      } else if (d.learn_sigma2) {
        sigma2_[s].setConstant(std::exp(eta_[s]));
        if (d.noise_mult.size()) sigma2_[s].array() *= d.noise_mult.array();
      } else {
        std::gamma_distribution<double> ga(0.5 * (d.R - 1.0), 1.0);
        for (int i = 0; i < n; ++i) sigma2_[s](i) = 0.5 * d.s2(i) / ga(rng_);
      }
      // the variance of wbar, sigma2 / R + extra, computed as (sigma2 + R extra) / R
      // so that extra = r gives the same numbers as sigma2 + R r; the
      // prior's scale is its mean, with a learned sigma2 at its prior's
      // scale (so that the tau2 prior does not depend on the learned sigma2)
      for (int i = 0; i < n; ++i) {
        const double e = sigma2_[s](i) + d.R * d.extra(i);
        ebar_[s](i) = e / d.R;
        const int g = d.group[i];
        const double ep = d.learn_sigma2 ? d.noise_scale * d.noise_scale * d.mult(i) + d.R * d.extra(i) : e;
        sigbar_(g) += spans_[g] ? ep / d.R * sites_[group_site_[g]].R : ep;
      }
    }
    for (int g = 0; g < G_; ++g) {
      if (group_count_[g] > 0) sigbar_(g) /= group_count_[g];
    }
  }

  // base = V + sigma2 / R + extra, resid2 = (wbar - m)^2 at the current inputs.
  void refresh_cache() {
    logs_valid_ = false;
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      base_[s] = v_[s] + ebar_[s];
      resid2_[s] = (d.wbar - m_[s]).array().square().matrix();
      if (shared_) resid_[s] = d.wbar - m_[s];
    }
  }

  Eigen::VectorXd moment_tau2(const std::vector<Eigen::VectorXd>& m,
                              const std::vector<Eigen::VectorXd>& v) const {
    Eigen::VectorXd out(G_);
    Eigen::VectorXd num = Eigen::VectorXd::Zero(G_), scale = Eigen::VectorXd::Zero(G_);
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      for (int i = 0; i < d.bank->n_coef(); ++i) {
        const double b = v[s](i) + ebar_[s](i);
        const double r = d.wbar(i) - m[s](i);
        num(d.group[i]) += r * r - b;
        scale(d.group[i]) += b + r * r;
      }
    }
    for (int g = 0; g < G_; ++g) {
      const double c = group_count_[g] > 0 ? group_count_[g] : 1.0;
      const double floor = std::max(1e-3 * scale(g) / c, 1e-12);
      out(g) = std::max(num(g) / c, floor);
    }
    return out;
  }

  // Log target of eta = log sigma2 of learned site s at the current inputs
  // and tau2: the field means' likelihood (and, with R >= 2, the replicates'
  // scatter about their mean; and the scatter of repeated measurements at
  // one time stamp) and the prior of eta. The tau2 priors' scale takes the
  // learned sigma2 at its prior's scale, so they do not enter.
  double noise_target(int s, double eta) const {
    const SiteData& d = sites_[s];
    const int n = d.bank->n_coef();
    const double sig2 = std::exp(eta);
    double ll = 0.0;
    if (shared_) {
      const int root = d.bias_of >= 0 ? d.bias_of : s;
      for (int i = 0; i < n; ++i) {
        ll += shared_term(root, tau2_(d.group[i]),
                          [&](int q) {
                            return q == s ? v_[s](i) + (sig2 * d.mult(i) + d.R * d.extra(i)) / d.R : base_[q](i);
                          },
                          [&](int q) { return resid_[q](i); });
        if (d.R >= 2.0) ll -= 0.5 * ((d.R - 1.0) * eta + d.s2(i) / (sig2 * d.mult(i)));
      }
    } else {
      for (int i = 0; i < n; ++i) {
        const double tot = v_[s](i) + (sig2 * d.mult(i) + d.R * d.extra(i)) / d.R + tau2_(d.group[i]);
        ll -= 0.5 * (std::log(tot) + resid2_[s](i) / tot);
        if (d.R >= 2.0) ll -= 0.5 * ((d.R - 1.0) * eta + d.s2(i) / (sig2 * d.mult(i)));
      }
    }
    if (d.noise_df > 0.0) ll -= 0.5 * (d.noise_df * eta + d.noise_ss / sig2);
    return set_.temper * ll + d.log_prior_eta(eta, set_.debug_break != 4);
  }

  // One coefficient's log likelihood over site s and the sites sharing its
  // bias: the field means y_k = wbar_k - m_k, of variance d_k (emulator and
  // field) each, share one bias of variance t2, so they are jointly normal
  // with covariance diag(d) + t2 1 1'. dk(q) and yk(q) give d and y at site q.
  template <class D, class Y>
  double shared_term(int s, double t2, D dk, Y yk) const {
    double A = 0.0, B = 0.0, C = 0.0, L = 0.0;
    auto add = [&](int q) {
      const double d = dk(q), y = yk(q);
      A += 1.0 / d;
      B += y / d;
      C += y * y / d;
      L += std::log(d);
    };
    add(s);
    for (int q : dependents_[s]) add(q);
    const double a = 1.0 + t2 * A;
    return -0.5 * (L + std::log(a) + C - t2 * B * B / a);
  }

  // The log likelihood, with a shared bias, of the coefficients that inform
  // the inputs (all of them with `all`): shared_term() of every site that
  // owns its bias, d and y of coefficient i at site q from dk(q, i), yk(q, i).
  template <class D, class Y>
  double shared_loglik(const Eigen::VectorXd& tau2, bool all, D dk, Y yk) const {
    double ll = 0.0;
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      if (d.bias_of >= 0) continue;
      for (int i = 0; i < d.bank->n_coef(); ++i) {
        if (!all && !informs_[d.group[i]]) continue;
        ll += shared_term(static_cast<int>(s), tau2(d.group[i]), [&](int q) { return dk(q, i); },
                          [&](int q) { return yk(q, i); });
      }
    }
    return set_.temper * ll;
  }

  // debug_break 5: the sites of an experiment with a change of the inputs
  // leave the inputs' target (to show that the checks see it).
  bool dropped(const SiteData& d) const { return set_.debug_break == 5 && d.shift.size() > 0; }

  double log_prior_tau(int g, double t2) const {
    return -std::log(t2 + sigbar_(g) / sites_[group_site_[g]].R);
  }

  // The log likelihoods of the field means (sampler_loglik.h), the target's:
  // raised to the power settings.temper (multiplied by it on the log scale),
  // so that every acceptance ratio takes them as they are.
  // At means m and variances v; at the proposal's (mp_, vp_) and the current
  // tau2 the logs are kept in logs_p_ for take_proposal().
  double loglik_with(const std::vector<Eigen::VectorXd>& m, const std::vector<Eigen::VectorXd>& v,
                     const Eigen::VectorXd& tau2) const;
  // Of the coefficients that inform the inputs (all of them with `all`), at
  // the cached m, V; at the current tau2 the logs are read from logs_, or
  // taken and kept there.
  double loglik(const Eigen::VectorXd& tau2, bool all = false) const;
  // Of tau2 group g's coefficients at its variance t2.
  double group_loglik(int g, double t2) const;
  // Group g's tau2 moved from `from` to tau2_(g), its likelihood last taken
  // there (group_loglik()): its logs enter logs_.
  void tau2_step_taken(int g, double from);

  void draw_coefficients(int h, SamplerOutput& out) {
    if (shared_) {
      draw_shared_coefficients(h, out);
      return;
    }
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      const int n = d.bank->n_coef();
      for (int i = 0; i < n; ++i) {
        double wb, wM;
        draw_bias_and_model(d.wbar(i), m_[s](i), v_[s](i), ebar_[s](i), tau2_(d.group[i]), rng_,
                            norm_, wb, wM);
        out.sigma2[s](h, i) = sigma2_[s](i);
        out.wb[s](h, i) = wb;
        out.wM[s](h, i) = wM;
      }
    }
  }

  // With a shared bias: the bias coefficient of site s and the sites sharing
  // it from its conditional given all their field means (normal, variance
  // t2 / (1 + t2 A), mean t2 B / (1 + t2 A) with A = sum 1 / d_k and
  // B = sum y_k / d_k), then each site's model coefficient from eq. (16)
  // given wbar_k - b.
  void draw_shared_coefficients(int h, SamplerOutput& out) {
    for (std::size_t s = 0; s < sites_.size(); ++s) {
      const SiteData& d = sites_[s];
      if (d.bias_of >= 0) continue;
      const int n = d.bank->n_coef();
      for (int i = 0; i < n; ++i) {
        const double t2 = tau2_(d.group[i]);
        double A = 0.0, B = 0.0;
        auto add = [&](int q) {
          const double dd = v_[q](i) + ebar_[q](i);
          A += 1.0 / dd;
          B += (sites_[q].wbar(i) - m_[q](i)) / dd;
        };
        add(static_cast<int>(s));
        for (int q : dependents_[s]) add(q);
        const double a = 1.0 + t2 * A;
        const double b = t2 * B / a + std::sqrt(t2 / a) * norm_(rng_);
        auto model = [&](int q) {
          const double V = v_[q](i), e = ebar_[q](i), S = V + e;
          const double w = sites_[q].wbar(i) - b;
          out.wb[q](h, i) = b;
          out.wM[q](h, i) = S > 0.0 ? V / S * w + e / S * m_[q](i) + std::sqrt(V * e / S) * norm_(rng_) : m_[q](i);
          out.sigma2[q](h, i) = sigma2_[q](i);
        };
        model(static_cast<int>(s));
        for (int q : dependents_[s]) model(q);
      }
    }
  }
};

}  // namespace wavevalid

#include "sampler_shifts.h"
#include "sampler_loglik.h"

#endif
