// The registration's error in the sampler (included by sampler_state.h; the
// members of SamplerState declared there): the shifts a (prior N(0,
// diag(reg_shift_var))) move the field means by shift_U a, wbar = wbar0 -
// shift_U a.
//
// Given the inputs, tau2 and sigma2 (the bias integrated out) the
// coefficients are independent normals, so a's conditional is normal,
// precision P = diag(1 / var) + temper sum_s U_s' D_s^-1 U_s and mean P^-1
// temper sum_s U_s' D_s^-1 (wbar0_s - m_s), D = V + sigma2 / R + extra +
// tau2: a Gibbs step (registration_shift_step()).
//
// The inputs' steps take the shifts integrated out (a partially collapsed
// Gibbs sampler, van Dyk and Park 2008): the inputs and the shifts can both
// move an event in time, and a step of the inputs given the shifts would be
// held where the shifts put the events. The marginal log likelihood of the
// informing coefficients is temper sum log N(wbar0 - m; 0, D) - log|P| / 2 +
// b' P^-1 b / 2 with b = temper sum_s U_s' D_s^-1 (wbar0_s - m_s) and P from
// those coefficients (up to a constant); the shifts are drawn from their
// conditional at the start of every cycle and before every saved draw, so
// that no step conditions on shifts older than the inputs.
#ifndef WAVEVALID_SAMPLER_SHIFTS_H
#define WAVEVALID_SAMPLER_SHIFTS_H

namespace wavevalid {

inline void SamplerState::registration_shift_step() {
  if (K_ == 0) return;
  Eigen::MatrixXd P = set_.reg_shift_var.cwiseInverse().asDiagonal();
  Eigen::VectorXd b = Eigen::VectorXd::Zero(K_);
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const SiteData& d = sites_[s];
    if (d.shift_U.cols() == 0 || dropped(d)) continue;
    const int n = d.bank->n_coef();
    Eigen::VectorXd w(n), y(n);
    for (int i = 0; i < n; ++i) {
      w(i) = set_.temper / (base_[s](i) + tau2_(d.group[i]));
      y(i) = w(i) * (d.wbar0(i) - m_[s](i));
    }
    P.noalias() += d.shift_U.transpose() * w.asDiagonal() * d.shift_U;
    b.noalias() += d.shift_U.transpose() * y;
  }
  Eigen::LLT<Eigen::MatrixXd> llt(P);
  Eigen::VectorXd xi(K_);
  for (int k = 0; k < K_; ++k) xi(k) = norm_(rng_);
  a_ = llt.solve(b) + llt.matrixU().solve(xi);
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    SiteData& d = sites_[s];
    if (d.shift_U.cols() == 0) continue;
    d.wbar = d.wbar0 - d.shift_U * a_;
  }
  refresh_cache();
}

// The inputs' target with the shifts integrated out, at means m and
// emulator variances v (see above).
inline double SamplerState::collapsed_loglik(const std::vector<Eigen::VectorXd>& m,
                                             const std::vector<Eigen::VectorXd>& v,
                                             const Eigen::VectorXd& tau2) const {
  Eigen::MatrixXd P = set_.reg_shift_var.cwiseInverse().asDiagonal();
  Eigen::VectorXd b = Eigen::VectorXd::Zero(K_);
  double ll = 0.0;
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const SiteData& d = sites_[s];
    if (dropped(d)) continue;
    const bool moved = d.shift_U.cols() > 0;
    const int n = d.bank->n_coef();
    Eigen::VectorXd w = Eigen::VectorXd::Zero(n), y = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      if (!informs_[d.group[i]]) continue;
      const double tot = v[s](i) + ebar_[s](i) + tau2(d.group[i]);
      const double r = (moved ? d.wbar0(i) : d.wbar(i)) - m[s](i);
      ll -= 0.5 * (std::log(tot) + r * r / tot);
      w(i) = set_.temper / tot;
      y(i) = w(i) * r;
    }
    if (!moved) continue;
    P.noalias() += d.shift_U.transpose() * w.asDiagonal() * d.shift_U;
    b.noalias() += d.shift_U.transpose() * y;
  }
  Eigen::LLT<Eigen::MatrixXd> llt(P);
  const Eigen::MatrixXd& L = llt.matrixLLT();
  double logdet = 0.0;
  for (int k = 0; k < K_; ++k) logdet += 2.0 * std::log(L(k, k));
  return set_.temper * ll - 0.5 * logdet + 0.5 * b.dot(llt.solve(b));
}

}  // namespace wavevalid

#endif
