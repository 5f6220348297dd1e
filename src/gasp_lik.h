// Profile likelihood of one GASP emulator (report section 4):
//   w(z) ~ GP(mu, 1/lambda, c(z, z') = exp(-sum_p beta_p |z_p - z'_p|^(2 - alpha_p)))
// on inputs scaled to the unit cube, with mu and lambda profiled out:
//   mu_hat = 1'R^-1 y / 1'R^-1 1,   sigma2_hat = (y - mu_hat)'R^-1(y - mu_hat) / K,
//   l(theta) = -K/2 log(2 pi sigma2_hat) - 1/2 log|R| - K/2,
// the concentrated likelihood of DiceKriging for a constant trend.
// theta = (log beta_1..p, alpha_1..p); R carries a fixed nugget g on its
// diagonal (0 unless needed as a numerical safeguard).
// The gradient is analytic: with u = R^-1 (y - mu_hat),
//   dl/dtheta = 1/2 tr[(u u' / sigma2_hat - R^-1) dR/dtheta].
// Also the emulator quantities at given parameters (gasp_finalize).
// The optimiser is in gasp_optim.h, the fit of a coefficient in gasp_fit.h.
// Free of R types.
#ifndef WAVEVALID_GASP_LIK_H
#define WAVEVALID_GASP_LIK_H

#include <Eigen/Dense>
#include <vector>
#include <cmath>
#include <limits>
#include <algorithm>
#include "vexp.h"

namespace wavevalid {

// Pairwise |d| and log|d| per input of a scaled design over the K(K-1)/2
// pairs j > k (k-major), computed once per design and shared by the fits of
// all coefficients.
struct GaspDist {
  int K = 0, p = 0, P = 0;
  Eigen::MatrixXd logd, d1, d2;  // P x p
  Eigen::MatrixXd logd_clip;      // log|d| bounded below by -745 (for the gradient in alpha)
  explicit GaspDist(const Eigen::MatrixXd& X) {
    K = static_cast<int>(X.rows());
    p = static_cast<int>(X.cols());
    P = K * (K - 1) / 2;
    logd.resize(P, p);
    d1.resize(P, p);
    for (int q = 0; q < p; ++q) {
      int idx = 0;
      for (int k = 0; k < K; ++k) {
        for (int j = k + 1; j < K; ++j) {
          const double d = std::abs(X(j, q) - X(k, q));
          logd(idx, q) = d > 0.0 ? std::log(d) : -1e300;  // exp(-1e300 * (2 - a)) = 0
          d1(idx, q) = d;
          ++idx;
        }
      }
    }
    d2 = d1.array().square().matrix();
    logd_clip = logd.array().max(-745.0).matrix();
    // mean and variance of log|d| per input, for the optimiser's preconditioner
    c.resize(p);
    v.resize(p);
    for (int q = 0; q < p; ++q) {
      double s1 = 0.0, s2 = 0.0;
      int m = 0;
      for (int i = 0; i < P; ++i) {
        if (d1(i, q) > 0.0) { s1 += logd(i, q); s2 += logd(i, q) * logd(i, q); ++m; }
      }
      c(q) = m > 0 ? s1 / m : 0.0;
      v(q) = m > 1 ? std::max(s2 / m - c(q) * c(q), 1e-2) : 1.0;
    }
  }
  Eigen::VectorXd c, v;  // mean and variance of log|d| per input
};

// Profile log-likelihood of one coefficient y on a design (through its
// distances). value() factorises R and keeps what gradient() needs, so the
// gradient is computed only at points where it is used.
// The lower triangle of the correlation matrix R (with `nugget` on its
// diagonal) at theta = (log beta, alpha) for the pairwise distances D; keeps
// T = beta d^(2 - alpha) by pair and input, S their sum and C = exp(-S)
// (the exps in wide vectors, to the bit as Eigen's, vexp.h).
inline void build_correlation(const GaspDist& D, const Eigen::VectorXd& theta, double nugget, Eigen::MatrixXd& T,
                              Eigen::ArrayXd& S, Eigen::ArrayXd& C, Eigen::MatrixXd& R) {
  const int p = static_cast<int>(T.cols()), K = static_cast<int>(R.rows());
  S.setZero();
  for (int q = 0; q < p; ++q) {
    const double lb = theta(q);
    const double a = theta(p + q);
    if (vexp_eigen_available && (a == 0.0 || a == 1.0)) {  // the two loops below in one pass
      scale_add_to((a == 0.0 ? D.d2 : D.d1).col(q).data(), std::exp(lb), T.col(q).data(), S.data(), T.rows());
      continue;
    }
    if (a == 0.0) {
      T.col(q).noalias() = std::exp(lb) * D.d2.col(q);
    } else if (a == 1.0) {
      T.col(q).noalias() = std::exp(lb) * D.d1.col(q);
    } else {
      if (vexp_eigen_available) {
        affine_eigen(D.logd.col(q).data(), 2.0 - a, lb, T.col(q).data(), T.rows());
        vexp_eigen(T.col(q).data(), T.col(q).data(), T.rows());
      } else {
        T.col(q) = ((2.0 - a) * D.logd.col(q).array() + lb).exp().matrix();
      }
    }
    if (vexp_eigen_available) {
      add_to(S.data(), T.col(q).data(), S.size());
    } else {
      S += T.col(q).array();
    }
  }
  if (vexp_eigen_available) {
    C = -S;
    vexp_eigen(C.data(), C.data(), C.size());
  } else {
    C = (-S).exp();
  }
  int idx = 0;
  for (int k = 0; k < K; ++k) {
    R(k, k) = 1.0 + nugget;
    for (int j = k + 1; j < K; ++j) R(j, k) = C(idx++);
  }
}

// R^-1 = L^-T L^-1 (lower triangle) from the lower Cholesky factor L, using
// the triangular structure of both factors (K^3 / 3 flops in all): column j
// of L^-1 by forward substitution from e_j, then the dots of its columns'
// segments. compute() takes the wide-vector kernels of vexp.h where they give
// Eigen's results to the bit, and eigen() is the code they stand for.
class InverseGram {
 public:
  void resize(int K) {
    Linv_.resize(K, K);
    LT_.resize(((K + 7) / 8) * 8, K);
    acc_.resize(LT_.rows(), 4);
  }

  void compute(const Eigen::MatrixXd& L, Eigen::MatrixXd& Ri) {
    factor_inverse(L);
    gram(Ri);
  }

  // The first stage: L^-1 (transposed in LT_, or in Linv_ without the kernels).
  void factor_inverse(const Eigen::MatrixXd& L) {
    if (!vexp_eigen_available) return eigen_inverse(L, Linv_);
    tri_inverse_t(L.data(), LT_.data(), static_cast<int>(L.rows()), static_cast<int>(LT_.rows()));
  }

  // The second stage: the lower triangle of R^-1 from L^-1 (after factor_inverse()).
  void gram(Eigen::MatrixXd& Ri) {
    if (!vexp_eigen_available) return eigen_gram(Linv_, Ri);
    gram_lower_t(LT_.data(), Ri.data(), acc_.data(), static_cast<int>(Ri.rows()), static_cast<int>(LT_.rows()));
  }

  // The product |L^-1|_inf |L^-1|_1 (after factor_inverse()), an upper bound of |R^-1|_1.
  double inverse_norm_bound(int K) {
    double inf = 0.0, one = 0.0;
    if (!vexp_eigen_available) {
      inf = Linv_.cwiseAbs().rowwise().sum().maxCoeff();
      one = Linv_.cwiseAbs().colwise().sum().maxCoeff();
      return inf * one;
    }
    const int Kp = static_cast<int>(LT_.rows());
    double* col = acc_.data();  // |L^-1| summed by column, lanes of LT_'s rows
    for (int j = 0; j < K; ++j) col[j] = 0.0;
    for (int i = 0; i < K; ++i) {  // column i of LT_: row i of L^-1, zero beyond lane i
      const double* r = LT_.data() + static_cast<std::ptrdiff_t>(i) * Kp;
      double s = 0.0;
      for (int j = 0; j <= i; ++j) {
        const double v = std::abs(r[j]);
        s += v;
        col[j] += v;
      }
      inf = std::max(inf, s);
    }
    for (int j = 0; j < K; ++j) one = std::max(one, col[j]);
    return inf * one;
  }

  static void eigen(const Eigen::MatrixXd& L, Eigen::MatrixXd& Linv, Eigen::MatrixXd& Ri) {
    eigen_inverse(L, Linv);
    eigen_gram(Linv, Ri);
  }

  static void eigen_inverse(const Eigen::MatrixXd& L, Eigen::MatrixXd& Linv) {
    const int K = static_cast<int>(L.rows());
    Linv.setZero();
    for (int j = 0; j < K; ++j) {
      Linv(j, j) = 1.0;
      for (int k = j; k < K; ++k) {
        const double xk = Linv(k, j) / L(k, k);
        Linv(k, j) = xk;
        const int rest = K - k - 1;
        if (rest > 0) Linv.col(j).segment(k + 1, rest) -= xk * L.col(k).segment(k + 1, rest);
      }
    }
  }

  static void eigen_gram(const Eigen::MatrixXd& Linv, Eigen::MatrixXd& Ri) {
    const int K = static_cast<int>(Linv.rows());
    for (int k = 0; k < K; ++k) {
      for (int j = k; j < K; ++j) Ri(j, k) = Linv.col(j).segment(j, K - j).dot(Linv.col(k).segment(j, K - j));
    }
  }

  const Eigen::MatrixXd& transposed() const { return LT_; }  // LT(j, i) = L^-1(i, j), after compute()

 private:
  Eigen::MatrixXd Linv_, LT_, acc_;
};

// Eigen's Cholesky factorisation, with the 1-norm of the factored matrix it
// keeps for its reciprocal condition number.
class LLTNorm : public Eigen::LLT<Eigen::MatrixXd> {
 public:
  double l1_norm() const { return m_l1_norm; }
};

class GaspLik {
 public:
  GaspLik(const GaspDist& D, const Eigen::VectorXd& y) : D_(D), y_(y) {
    K_ = D.K;
    p_ = D.p;
    P_ = D.P;
    T_.resize(P_, p_);
    S_.resize(P_);
    R_.resize(K_, K_);
    Ri_.resize(K_, K_);
    inverse_.resize(K_);
    Mp_.resize(P_);
    mt_.resize(P_);
    ones_ = Eigen::VectorXd::Ones(K_);
  }

  int n_runs() const { return K_; }
  int n_inputs() const { return p_; }
  const GaspDist& dist() const { return D_; }
  int n_eval = 0, n_grad = 0;

  // Fills R (correlation + nugget) for theta; keeps T_ = beta d^(2 - alpha) per pair.
  void build(const Eigen::VectorXd& theta, double nugget) { build_correlation(D_, theta, nugget, T_, S_, C_, R_); }

  // Profile log-likelihood at theta; -inf when R is numerically singular.
  double value(const Eigen::VectorXd& theta, double nugget, double rcond_fail) {
    // the point of the last successful evaluation again (the optimum, once
    // the optimiser stops there): what value() keeps is that point's
    if (ok_ && nugget == last_nugget_ && rcond_fail <= last_fail_ && theta.size() == last_theta_.size() &&
        (theta.array() == last_theta_.array()).all()) {
      return last_value_;
    }
    ++n_eval;
    ok_ = false;
    build(theta, nugget);
    llt_.compute(R_);  // reads the lower triangle only
    if (llt_.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
    rcond_known_ = false;
    inverse_ready_ = false;
    if (!(rcond_fail > 0.0 && well_conditioned(rcond_fail))) {
      if (!(rcond() >= rcond_fail)) return -std::numeric_limits<double>::infinity();
    }
    a_ = llt_.solve(ones_);
    b_ = llt_.solve(y_);
    mu_ = ones_.dot(b_) / ones_.dot(a_);
    u_ = b_ - mu_ * a_;  // R^-1 (y - mu)
    const double s2 = (y_.array() - mu_).matrix().dot(u_) / K_;
    if (!(s2 > 0.0) || !std::isfinite(s2)) return -std::numeric_limits<double>::infinity();
    sigma2_ = s2;
    const Eigen::MatrixXd& L = llt_.matrixLLT();
    double logdet = 0.0;
    for (int k = 0; k < K_; ++k) logdet += std::log(L(k, k));
    logdet *= 2.0;
    ok_ = true;
    last_theta_ = theta;
    last_nugget_ = nugget;
    last_fail_ = rcond_fail;
    last_value_ = -0.5 * K_ * std::log(2.0 * M_PI * s2) - 0.5 * logdet - 0.5 * K_;
    return last_value_;
  }

  // Gradient in (log beta, alpha) at the point of the last successful value():
  //   dl/dtheta = 1/2 tr[(u u' / s2 - R^-1) dR/dtheta], dR_jk = -C_jk dS_jk.
  void gradient(Eigen::VectorXd& grad) {
    ++n_grad;
    grad.resize(2 * p_);
    if (!inverse_ready_) inverse_.factor_inverse(llt_.matrixLLT());
    inverse_.gram(Ri_);  // R^-1, lower triangle
    int idx = 0;
    const double is2 = 1.0 / sigma2_;
    for (int k = 0; k < K_; ++k) {
      const double uk = u_(k) * is2;
      // factor 2 (symmetry) times 1/2
      if (vexp_eigen_available) {
        scaled_difference(u_.data() + k + 1, uk, Ri_.data() + static_cast<std::ptrdiff_t>(k) * K_ + k + 1, C_.data() + idx,
                          Mp_.data() + idx, K_ - k - 1);
        idx += K_ - k - 1;
        continue;
      }
      for (int j = k + 1; j < K_; ++j) {
        Mp_(idx) = (u_(j) * uk - Ri_(j, k)) * C_(idx);
        ++idx;
      }
    }
    for (int q = 0; q < p_; ++q) {
      if (vexp_eigen_available && P_ >= 4) {  // the two sums below, to the bit, in one pass
        double s = 0.0, sl = 0.0;
        product_sums(Mp_.data(), T_.col(q).data(), D_.logd_clip.col(q).data(), P_, &s, &sl);
        grad(q) = -s;
        grad(p_ + q) = sl;
        continue;
      }
      mt_ = Mp_ * T_.col(q).array();
      grad(q) = -mt_.sum();
      grad(p_ + q) = (mt_ * D_.logd_clip.col(q).array()).sum();
    }
  }

  double eval(const Eigen::VectorXd& theta, double nugget, Eigen::VectorXd* grad, double rcond_fail) {
    const double ll = value(theta, nugget, rcond_fail);
    if (grad && std::isfinite(ll)) gradient(*grad);
    return ll;
  }

  double mu() const { return mu_; }
  double sigma2() const { return sigma2_; }
  // Eigen's estimate of the reciprocal condition number of R at the last
  // factorisation (computed when first asked).
  double rcond() {
    if (!rcond_known_) {
      rcond_ = llt_.rcond();
      rcond_known_ = true;
    }
    return rcond_;
  }

 private:
  // Whether Eigen's estimate llt_.rcond() is at least `thr`, shown without
  // computing it where a lower bound is: the estimate is 1 / (|R|_1 |R^-1 v|_1)
  // for vectors v of unit norm (Hager's method), |R^-1 v|_1 <= |R^-1|_1 <=
  // |L^-1|_inf |L^-1|_1 with L^-1 the inverse Cholesky factor, which the
  // gradient needs anyway (kept). The bound is taken with a margin of 1000
  // for the rounding of the estimate's solves (relative kappa K eps, at most
  // about 1e-3 there).
  bool well_conditioned(double thr) {
    inverse_.factor_inverse(llt_.matrixLLT());
    inverse_ready_ = true;
    return 1.0 / (llt_.l1_norm() * inverse_.inverse_norm_bound(K_)) >= 1e3 * thr;
  }

  const GaspDist& D_;
  Eigen::VectorXd y_;
  int K_, p_, P_;
  Eigen::MatrixXd T_, R_, Ri_;
  InverseGram inverse_;
  Eigen::ArrayXd S_, C_, Mp_, mt_;
  Eigen::VectorXd ones_, u_, a_, b_;
  LLTNorm llt_;
  double mu_ = 0.0, sigma2_ = 0.0, rcond_ = 0.0;
  bool ok_ = false, rcond_known_ = false, inverse_ready_ = false;
  Eigen::VectorXd last_theta_;
  double last_nugget_ = 0.0, last_fail_ = 0.0, last_value_ = 0.0;
};

// Quantities of a fitted emulator at given (beta, alpha, nugget): mu, lambda,
// weights R^-1 (y - mu), lower Cholesky factor and log-likelihood. If R is not
// positive definite at `nugget`, the nugget is increased along the ladder.
struct GaspFinal {
  double mu = 0.0, lambda = 0.0, nugget = 0.0, loglik = 0.0;
  Eigen::VectorXd weights;
  Eigen::MatrixXd L;
  bool ok = false;
};

// The correlation matrix of the design at (beta, alpha) and its Cholesky
// factorisation, with the nugget raised along the ladder until R is
// positive definite and well conditioned (ok false if it never is).
struct GaspFactor {
  Eigen::LLT<Eigen::MatrixXd> llt;
  double nugget = 0.0;
  bool ok = false;
};

// The distances |d| of the pairs j > k (k-major) per input of a design, and
// std::pow(|d|, 2) and std::pow(|d|, 1): the powers of the inputs whose alpha
// is 0 or 1 (most of them), computed once for the coefficients of a design
// with the same calls as gasp_factor() makes for the others.
struct GaspPowers {
  Eigen::MatrixXd d, sq, id;  // K (K - 1) / 2 x p
  explicit GaspPowers(const Eigen::MatrixXd& X) {
    const int K = static_cast<int>(X.rows()), p = static_cast<int>(X.cols());
    const int P = K * (K - 1) / 2;
    d.resize(P, p);
    sq.resize(P, p);
    id.resize(P, p);
    volatile double two = 2.0, one = 1.0;  // the library's pow, as for any exponent
    for (int q = 0; q < p; ++q) {
      int idx = 0;
      for (int k = 0; k < K; ++k) {
        for (int j = k + 1; j < K; ++j) {
          const double v = std::abs(X(j, q) - X(k, q));
          d(idx, q) = v;
          sq(idx, q) = std::pow(v, static_cast<double>(two));
          id(idx, q) = std::pow(v, static_cast<double>(one));
          ++idx;
        }
      }
    }
  }
};

// With `pw` (GaspPowers of X), the powers for alpha 0 and 1 are read from it.
inline GaspFactor gasp_factor(const Eigen::MatrixXd& X, const Eigen::VectorXd& beta, const Eigen::VectorXd& alpha,
                              double nugget, const GaspPowers* pw = nullptr) {
  const int K = static_cast<int>(X.rows()), p = static_cast<int>(X.cols());
  GaspFactor out;
  Eigen::MatrixXd R(K, K);
  int idx = 0;
  for (int k = 0; k < K; ++k) {
    R(k, k) = 1.0;
    for (int j = k + 1; j < K; ++j, ++idx) {
      double s = 0.0;
      for (int q = 0; q < p; ++q) {
        if (beta(q) == 0.0) continue;
        const double e = 2.0 - alpha(q);
        if (pw) {
          const double d = pw->d(idx, q);
          if (!(d > 0.0)) continue;
          s += beta(q) * (e == 2.0 ? pw->sq(idx, q) : e == 1.0 ? pw->id(idx, q) : std::pow(d, e));
        } else {
          const double d = std::abs(X(j, q) - X(k, q));
          if (d > 0.0) s += beta(q) * std::pow(d, e);
        }
      }
      R(j, k) = R(k, j) = std::exp(-s);
    }
  }
  static const double ladder[] = {1e-8, 1e-6, 1e-4, 1e-2, 1.0};
  std::vector<double> tries(1, nugget);
  for (double g : ladder) if (g > nugget) tries.push_back(g);
  for (double g : tries) {
    Eigen::MatrixXd Rg = R;
    Rg.diagonal().array() += g;
    out.llt.compute(Rg);
    if (out.llt.info() == Eigen::Success && out.llt.rcond() >= 1e-15) {
      out.nugget = g;
      out.ok = true;
      break;
    }
  }
  return out;
}

// mu, lambda, weights and log-likelihood of coefficient values y under a
// factorised correlation; the factor itself in L when `with_L`.
inline GaspFinal gasp_finish(const GaspFactor& f, const Eigen::VectorXd& y, bool with_L = true) {
  GaspFinal out;
  if (!f.ok) return out;
  out.ok = true;
  out.nugget = f.nugget;
  const int K = static_cast<int>(y.size());
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(K);
  const Eigen::VectorXd a = f.llt.solve(ones), b = f.llt.solve(y);
  out.mu = ones.dot(b) / ones.dot(a);
  out.weights = b - out.mu * a;
  const double s2 = (y.array() - out.mu).matrix().dot(out.weights) / K;
  out.lambda = 1.0 / s2;
  if (with_L) out.L = f.llt.matrixL();
  double logdet = 0.0;
  for (int k = 0; k < K; ++k) logdet += std::log(f.llt.matrixLLT()(k, k));
  out.loglik = -0.5 * K * std::log(2.0 * M_PI * s2) - logdet - 0.5 * K;
  return out;
}

inline GaspFinal gasp_finalize(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                               const Eigen::VectorXd& beta, const Eigen::VectorXd& alpha,
                               double nugget) {
  return gasp_finish(gasp_factor(X, beta, alpha, nugget), y, true);
}

}  // namespace wavevalid

#endif
