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

// The shifts' precision and right-hand side started at the prior's:
// P = diag(1 / var), b = 0.
inline void SamplerState::shift_start() const {
  shift_P_.setZero();
  shift_P_.diagonal() = set_.reg_shift_var.cwiseInverse();
  shift_b_.setZero();
}

// The r-th coefficient that the shifts move at site s (row u of shift_U),
// of weight w and weighted residual y: P += w u u' (its lower triangle, which
// the Cholesky factorisation reads), b += y u. The rows a shift leaves
// unchanged add nothing.
inline void SamplerState::shift_add(int s, int r, double w, double y) const {
  const double* u = shift_Ur_[s].data() + static_cast<std::size_t>(r) * K_;
  for (int j = 0; j < K_; ++j) {
    const double wu = w * u[j];
    for (int k = j; k < K_; ++k) shift_P_(k, j) += wu * u[k];
    shift_b_(j) += y * u[j];
  }
}

// The field means of site s at the current shifts, wbar = wbar0 - shift_U a,
// and (with `resid`) their squared residuals at the current means, on the
// coefficients the shifts move (the others keep wbar0).
inline void SamplerState::shift_moved(int s, bool resid) {
  SiteData& d = sites_[s];
  const std::vector<int>& rows = shift_rows_[s];
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const int i = rows[r];
    const double* u = shift_Ur_[s].data() + r * K_;
    double du = 0.0;
    for (int k = 0; k < K_; ++k) du += u[k] * a_(k);
    d.wbar(i) = d.wbar0(i) - du;
    if (!resid) continue;
    const double e = d.wbar(i) - m_[s](i);
    resid2_[s](i) = e * e;
  }
}

inline void SamplerState::registration_shift_step() {
  if (K_ == 0) return;
  shift_start();
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const SiteData& d = sites_[s];
    if (d.shift_U.cols() == 0 || dropped(d)) continue;
    const std::vector<int>& rows = shift_rows_[s];
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const int i = rows[r];
      const double w = set_.temper / (base_[s](i) + tau2_(d.group[i]));
      shift_add(static_cast<int>(s), static_cast<int>(r), w, w * (d.wbar0(i) - m_[s](i)));
    }
  }
  Eigen::LLT<Eigen::MatrixXd> llt(shift_P_);
  Eigen::VectorXd xi(K_);
  for (int k = 0; k < K_; ++k) xi(k) = norm_(rng_);
  a_ = llt.solve(shift_b_) + llt.matrixU().solve(xi);
  for (std::size_t s = 0; s < sites_.size(); ++s)
    if (sites_[s].shift_U.cols() > 0) shift_moved(static_cast<int>(s), true);
}

// The inputs' target with the shifts integrated out, at means m and
// emulator variances v (see above). It does not depend on the current
// shifts. The logs of the variances are read from logs_in, or taken and
// kept in logs_out (SamplerState::logs_).
inline double SamplerState::collapsed_loglik(const std::vector<Eigen::VectorXd>& m,
                                             const std::vector<Eigen::VectorXd>& v,
                                             const Eigen::VectorXd& tau2,
                                             const std::vector<Eigen::VectorXd>* logs_in,
                                             std::vector<Eigen::VectorXd>* logs_out) const {
  shift_start();
  double ll = 0.0;
  for (std::size_t s = 0; s < sites_.size(); ++s) {
    const SiteData& d = sites_[s];
    if (dropped(d)) continue;
    const bool moved = d.shift_U.cols() > 0;
    const std::vector<int>& rows = shift_rows_[s];
    const std::size_t nr = moved ? rows.size() : 0;
    std::size_t r = 0;
    const int n = d.bank->n_coef();
    for (int i = 0; i < n; ++i) {
      const bool hit = r < nr && rows[r] == i;
      const int ri = static_cast<int>(r);
      if (hit) ++r;
      if (!informs_[d.group[i]]) continue;
      const double tot = v[s](i) + ebar_[s](i) + tau2(d.group[i]);
      const double res = (moved ? d.wbar0(i) : d.wbar(i)) - m[s](i);
      const double lt = logs_in ? (*logs_in)[s](i) : std::log(tot);
      if (logs_out) (*logs_out)[s](i) = lt;
      ll -= 0.5 * (lt + res * res / tot);
      if (hit) {
        const double w = set_.temper / tot;
        shift_add(static_cast<int>(s), ri, w, w * res);
      }
    }
  }
  Eigen::LLT<Eigen::MatrixXd> llt(shift_P_);
  const Eigen::MatrixXd& L = llt.matrixLLT();
  double logdet = 0.0;
  for (int k = 0; k < K_; ++k) logdet += 2.0 * std::log(L(k, k));
  return set_.temper * ll - 0.5 * logdet + 0.5 * shift_b_.dot(llt.solve(shift_b_));
}

}  // namespace wavevalid

#endif
