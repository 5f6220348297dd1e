// The log likelihoods of the field means in the sampler (included by
// sampler_state.h; the members of SamplerState declared there): at given
// means and variances, at the cached ones, and of one tau2 group's
// coefficients, each log of a coefficient's variance taken once where it is
// kept (SamplerState::logs_).
#ifndef WAVEVALID_SAMPLER_LOGLIK_H
#define WAVEVALID_SAMPLER_LOGLIK_H

namespace wavevalid {

inline double SamplerState::loglik_with(const std::vector<Eigen::VectorXd>& m,
                                        const std::vector<Eigen::VectorXd>& v,
                                        const Eigen::VectorXd& tau2) const {
  logs_p_valid_ = log_cache_ && &m == &mp_ && &v == &vp_ && &tau2 == &tau2_;
  std::vector<Eigen::VectorXd>* out = logs_p_valid_ ? &logs_p_ : nullptr;
  if (collapsed()) return collapsed_loglik(m, v, tau2, nullptr, out);
  if (shared_) {
    return shared_loglik(tau2, false, [&](int q, int i) { return v[q](i) + ebar_[q](i); },
                         [&](int q, int i) { return sites_[q].wbar(i) - m[q](i); });
  }
  double ll = 0.0;
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const SiteData& d = sites_[s];
    if (dropped(d)) continue;
    const int n = d.bank->n_coef();
    for (int i = 0; i < n; ++i) {
      if (!informs_[d.group[i]]) continue;
      const double tot = v[s](i) + ebar_[s](i) + tau2(d.group[i]);
      const double r = d.wbar(i) - m[s](i);
      const double lt = std::log(tot);
      if (out) (*out)[s](i) = lt;
      ll -= 0.5 * (lt + r * r / tot);
    }
  }
  return set_.temper * ll;
}

inline double SamplerState::loglik(const Eigen::VectorXd& tau2, bool all) const {
  const bool here = log_cache_ && !all && &tau2 == &tau2_;
  const std::vector<Eigen::VectorXd>* in = here && logs_valid_ ? &logs_ : nullptr;
  std::vector<Eigen::VectorXd>* out = here && !logs_valid_ ? &logs_ : nullptr;
  if (here) logs_valid_ = true;
  if (!all && collapsed()) return collapsed_loglik(m_, v_, tau2, in, out);
  if (shared_) {
    return shared_loglik(tau2, all, [&](int q, int i) { return base_[q](i); },
                         [&](int q, int i) { return resid_[q](i); });
  }
  double ll = 0.0;
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const SiteData& d = sites_[s];
    if (dropped(d)) continue;
    const int n = d.bank->n_coef();
    for (int i = 0; i < n; ++i) {
      if (!all && !informs_[d.group[i]]) continue;
      const double tot = base_[s](i) + tau2(d.group[i]);
      const double lt = in ? (*in)[s](i) : std::log(tot);
      if (out) (*out)[s](i) = lt;
      ll -= 0.5 * (lt + resid2_[s](i) / tot);
    }
  }
  return set_.temper * ll;
}

inline double SamplerState::group_loglik(int g, double t2) const {
  if (shared_) {
    double ll = 0.0;
    for (std::size_t k = 0; k < members_[g].size(); ++k) {
      const int s = msite_[g][k], i = members_[g][k];
      if (sites_[s].bias_of >= 0) continue;
      ll += shared_term(s, t2, [&](int q) { return base_[q](i); }, [&](int q) { return resid_[q](i); });
    }
    return set_.temper * ll;
  }
  // at the group's current tau2 the logs are read from logs_; at another
  // they are kept in glogs_ (for tau2_step_taken())
  const bool cur = log_cache_ && logs_valid_ && t2 == tau2_(g);
  const bool keep = log_cache_ && !cur;
  double ll = 0.0;
  for (std::size_t k = 0; k < members_[g].size(); ++k) {
    const int s = msite_[g][k], i = members_[g][k];
    const double tot = base_[s](i) + t2;
    const double lt = cur ? logs_[s](i) : std::log(tot);
    if (keep) glogs_(static_cast<Eigen::Index>(k)) = lt;
    ll -= 0.5 * (lt + resid2_[s](i) / tot);
  }
  return set_.temper * ll;
}

inline void SamplerState::tau2_step_taken(int g, double from) {
  if (!logs_valid_ || tau2_(g) == from) return;
  for (std::size_t k = 0; k < members_[g].size(); ++k)
    logs_[msite_[g][k]](members_[g][k]) = glogs_(static_cast<Eigen::Index>(k));
}

}  // namespace wavevalid

#endif
