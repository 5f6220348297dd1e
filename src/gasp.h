// Maximum-likelihood fitting of one GASP emulator (report section 4):
//   w(z) ~ GP(mu, 1/lambda, c(z, z') = exp(-sum_p beta_p |z_p - z'_p|^(2 - alpha_p)))
// on inputs scaled to the unit cube, with mu and lambda profiled out:
//   mu_hat = 1'R^-1 y / 1'R^-1 1,   sigma2_hat = (y - mu_hat)'R^-1(y - mu_hat) / K,
//   l(theta) = -K/2 log(2 pi sigma2_hat) - 1/2 log|R| - K/2,
// the concentrated likelihood of DiceKriging for a constant trend.
// theta = (log beta_1..p, alpha_1..p); R carries a fixed nugget g on its
// diagonal (0 unless needed as a numerical safeguard).
// The gradient is analytic: with u = R^-1 (y - mu_hat),
//   dl/dtheta = 1/2 tr[(u u' / sigma2_hat - R^-1) dR/dtheta].
// The optimiser is a projected limited-memory BFGS on the box
// log beta in [lb_lo, lb_hi], alpha in [0, 1], run from several deterministic
// starts. Free of R types.
#ifndef WAVEVALID_GASP_H
#define WAVEVALID_GASP_H

#include <Eigen/Dense>
#include <vector>
#include <deque>
#include <cmath>
#include <limits>
#include <algorithm>

namespace wavevalid {

struct GaspSettings {
  double lb_lo = -8.0;       // lower bound of log beta
  double lb_hi = 6.0;        // upper bound of log beta
  int maxit = 200;           // iterations of the final polish of the best start
  int maxit_explore = 25;    // iterations per start before the best one is polished
  double pgtol = 1e-5;       // projected-gradient tolerance
  double ftol = 1e-8;        // change of the objective (per unit of |loglik|)
  double rcond_fail = 1e-14; // below: the point counts as numerically singular
  double rcond_ok = 1e-12;   // below at the optimum: retry with a larger nugget
  int memory = 8;            // L-BFGS memory
};

// Pairwise distances of a scaled design, stored over the K(K-1)/2 pairs j < k.
class GaspLik {
 public:
  GaspLik(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) : X_(X), y_(y) {
    K_ = static_cast<int>(X.rows());
    p_ = static_cast<int>(X.cols());
    P_ = K_ * (K_ - 1) / 2;
    logd_.resize(P_, p_);
    d1_.resize(P_, p_);
    int idx = 0;
    for (int k = 0; k < K_; ++k) {
      for (int j = k + 1; j < K_; ++j) {
        for (int q = 0; q < p_; ++q) {
          const double d = std::abs(X(j, q) - X(k, q));
          logd_(idx, q) = d > 0.0 ? std::log(d) : -1e300;  // exp(-1e300 * (2 - a)) = 0
          d1_(idx, q) = d;
        }
        ++idx;
      }
    }
    d2_ = d1_.array().square().matrix();
    T_.resize(P_, p_);
    R_.resize(K_, K_);
    ones_ = Eigen::VectorXd::Ones(K_);
    I_ = Eigen::MatrixXd::Identity(K_, K_);
  }

  int n_runs() const { return K_; }
  int n_inputs() const { return p_; }
  int n_eval = 0;

  // Fills R (correlation + nugget) for theta; keeps T_ = beta d^(2 - alpha) per pair.
  void build(const Eigen::VectorXd& theta, double nugget) {
    Eigen::ArrayXd S = Eigen::ArrayXd::Zero(P_);
    for (int q = 0; q < p_; ++q) {
      const double b = std::exp(theta(q));
      const double a = theta(p_ + q);
      if (a == 0.0) {
        T_.col(q) = b * d2_.col(q);
      } else if (a == 1.0) {
        T_.col(q) = b * d1_.col(q);
      } else {
        T_.col(q) = b * ((2.0 - a) * logd_.col(q).array()).exp().matrix();
      }
      S += T_.col(q).array();
    }
    C_ = (-S).exp();
    int idx = 0;
    for (int k = 0; k < K_; ++k) {
      R_(k, k) = 1.0 + nugget;
      for (int j = k + 1; j < K_; ++j) {
        R_(j, k) = C_(idx);
        R_(k, j) = C_(idx);
        ++idx;
      }
    }
  }

  // Profile log-likelihood at theta; gradient in grad if non-null.
  // Returns -inf when R is numerically singular.
  double eval(const Eigen::VectorXd& theta, double nugget, Eigen::VectorXd* grad,
              double rcond_fail) {
    ++n_eval;
    build(theta, nugget);
    llt_.compute(R_);
    if (llt_.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
    rcond_ = llt_.rcond();
    if (!(rcond_ >= rcond_fail)) return -std::numeric_limits<double>::infinity();
    const Eigen::VectorXd a = llt_.solve(ones_);
    const Eigen::VectorXd b = llt_.solve(y_);
    mu_ = ones_.dot(b) / ones_.dot(a);
    u_ = b - mu_ * a;  // R^-1 (y - mu)
    const double s2 = (y_.array() - mu_).matrix().dot(u_) / K_;
    if (!(s2 > 0.0) || !std::isfinite(s2)) return -std::numeric_limits<double>::infinity();
    sigma2_ = s2;
    const Eigen::MatrixXd& L = llt_.matrixLLT();
    double logdet = 0.0;
    for (int k = 0; k < K_; ++k) logdet += std::log(L(k, k));
    logdet *= 2.0;
    const double ll = -0.5 * K_ * std::log(2.0 * M_PI * s2) - 0.5 * logdet - 0.5 * K_;
    if (grad) {
      Eigen::MatrixXd Linv = I_;
      llt_.matrixL().solveInPlace(Linv);
      Eigen::MatrixXd Ri = Eigen::MatrixXd::Zero(K_, K_);
      Ri.selfadjointView<Eigen::Lower>().rankUpdate(Linv.transpose());
      // Off-diagonal pair weights of M = (u u'/s2 - R^-1); diagonal of dR is 0.
      Eigen::ArrayXd Mp(P_);
      int idx = 0;
      for (int k = 0; k < K_; ++k) {
        for (int j = k + 1; j < K_; ++j) {
          Mp(idx++) = u_(j) * u_(k) / s2 - Ri(j, k);  // lower triangle of Ri
        }
      }
      Mp *= C_;  // dR_jk = C_jk * d(-S_jk); factor 2 (symmetry) times 1/2
      grad->resize(2 * p_);
      for (int q = 0; q < p_; ++q) {
        const Eigen::ArrayXd t = T_.col(q).array();
        (*grad)(q) = -(Mp * t).sum();
        (*grad)(p_ + q) = (Mp * t * logd_.col(q).array().max(-745.0)).sum();
      }
    }
    return ll;
  }

  double mu() const { return mu_; }
  double sigma2() const { return sigma2_; }
  double rcond() const { return rcond_; }

 private:
  Eigen::MatrixXd X_;
  Eigen::VectorXd y_;
  int K_, p_, P_;
  Eigen::MatrixXd logd_, d1_, d2_, T_, R_, I_;
  Eigen::ArrayXd C_;
  Eigen::VectorXd ones_, u_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  double mu_ = 0.0, sigma2_ = 0.0, rcond_ = 0.0;
};

struct GaspOptResult {
  Eigen::VectorXd theta;
  double loglik = -std::numeric_limits<double>::infinity();
  int iterations = 0;
  bool converged = false;
};

// Projected L-BFGS maximising the profile log-likelihood on the box [lo, hi].
inline GaspOptResult gasp_optimise(GaspLik& lik, Eigen::VectorXd x, double nugget,
                                   const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                                   const GaspSettings& set) {
  const int n = static_cast<int>(x.size());
  x = x.cwiseMax(lo).cwiseMin(hi);
  Eigen::VectorXd g(n), g_new(n);
  // minimise f = -loglik
  double f = -lik.eval(x, nugget, &g, set.rcond_fail);
  g = -g;
  GaspOptResult res;
  res.theta = x;
  if (!std::isfinite(f)) return res;
  std::deque<Eigen::VectorXd> S, Y;
  std::deque<double> rho;
  const double bound_eps = 1e-10;
  int small_steps = 0;
  int it = 0;
  for (; it < set.maxit; ++it) {
    // free variables: not held at a bound by the gradient
    Eigen::Array<bool, Eigen::Dynamic, 1> fr(n);
    for (int i = 0; i < n; ++i) {
      fr(i) = !((x(i) <= lo(i) + bound_eps && g(i) > 0.0) || (x(i) >= hi(i) - bound_eps && g(i) < 0.0));
    }
    // projected-gradient convergence test
    const Eigen::VectorXd pg = (x - g).cwiseMax(lo).cwiseMin(hi) - x;
    if (pg.lpNorm<Eigen::Infinity>() < set.pgtol) {
      res.converged = true;
      break;
    }
    // two-loop recursion on the free subspace
    Eigen::VectorXd q = g;
    for (int i = 0; i < n; ++i) if (!fr(i)) q(i) = 0.0;
    const int m = static_cast<int>(S.size());
    std::vector<double> al(m);
    for (int j = m - 1; j >= 0; --j) {
      al[j] = rho[j] * S[j].dot(q);
      q -= al[j] * Y[j];
      for (int i = 0; i < n; ++i) if (!fr(i)) q(i) = 0.0;
    }
    double gamma = 1.0;
    if (m > 0) gamma = S[m - 1].dot(Y[m - 1]) / Y[m - 1].squaredNorm();
    Eigen::VectorXd d = gamma * q;
    for (int j = 0; j < m; ++j) {
      const double be = rho[j] * Y[j].dot(d);
      d += S[j] * (al[j] - be);
      for (int i = 0; i < n; ++i) if (!fr(i)) d(i) = 0.0;
    }
    d = -d;
    double slope = g.dot(d);
    if (!(slope < 0.0)) {
      S.clear(); Y.clear(); rho.clear();
      d = -g;
      for (int i = 0; i < n; ++i) if (!fr(i)) d(i) = 0.0;
      slope = g.dot(d);
      if (!(slope < 0.0)) { res.converged = true; break; }
    }
    if (m == 0) {  // first step: at most one unit in any coordinate
      const double dn = d.lpNorm<Eigen::Infinity>();
      if (dn > 1.0) d /= dn;
    }
    // backtracking Armijo search along the projected path
    double step = 1.0, f_new = std::numeric_limits<double>::infinity();
    Eigen::VectorXd x_new(n);
    bool ok = false;
    for (int ls = 0; ls < 40; ++ls) {
      x_new = (x + step * d).cwiseMax(lo).cwiseMin(hi);
      f_new = -lik.eval(x_new, nugget, &g_new, set.rcond_fail);
      if (std::isfinite(f_new) && f_new <= f + 1e-4 * g.dot(x_new - x)) {
        ok = true;
        break;
      }
      step *= 0.5;
    }
    if (!ok) {
      if (m > 0) {  // retry from steepest descent with the memory cleared
        S.clear(); Y.clear(); rho.clear();
        continue;
      }
      break;
    }
    g_new = -g_new;
    const Eigen::VectorXd s = x_new - x, yv = g_new - g;
    const double sy = s.dot(yv);
    if (sy > 1e-10 * s.norm() * yv.norm()) {
      if (static_cast<int>(S.size()) == set.memory) { S.pop_front(); Y.pop_front(); rho.pop_front(); }
      S.push_back(s); Y.push_back(yv); rho.push_back(1.0 / sy);
    }
    const double df = f - f_new;
    x = x_new; g = g_new; f = f_new;
    if (df <= set.ftol * std::max(1.0, std::abs(f))) {
      if (++small_steps >= 2) { res.converged = true; ++it; break; }
    } else {
      small_steps = 0;
    }
  }
  res.theta = x;
  res.loglik = -f;
  res.iterations = it;
  return res;
}

// Radical inverse in base b (Halton sequence), for deterministic starts.
inline double halton(int i, int b) {
  double f = 1.0, r = 0.0;
  while (i > 0) { f /= b; r += f * (i % b); i /= b; }
  return r;
}

struct GaspFit {
  Eigen::VectorXd theta;  // (log beta, alpha)
  double nugget = 0.0;
  double loglik = -std::numeric_limits<double>::infinity();
  int n_eval = 0;
  bool converged = false;
};

// Fits one coefficient: data-driven isotropic start plus Halton starts over
// log beta in [-4, 2], alpha in [0, 1]; nugget increased along `ladder`
// while the optimum is numerically singular.
inline GaspFit gasp_fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, int n_starts,
                        const GaspSettings& set) {
  static const double ladder[] = {0.0, 1e-8, 1e-6, 1e-4, 1e-2};
  GaspLik lik(X, y);
  const int p = lik.n_inputs();
  Eigen::VectorXd lo(2 * p), hi(2 * p);
  lo.head(p).setConstant(set.lb_lo); hi.head(p).setConstant(set.lb_hi);
  lo.tail(p).setZero(); hi.tail(p).setOnes();
  const int primes[] = {2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71,
                        73, 79, 83, 89, 97, 101, 103, 107, 109, 113, 127, 131, 137, 139, 149, 151};
  const int n_primes = sizeof(primes) / sizeof(int);
  GaspFit best;
  for (double nug : ladder) {
    // data-driven start: best common log beta on a grid, alpha = 0.5
    Eigen::VectorXd th(2 * p);
    double best_iso = -std::numeric_limits<double>::infinity(), lb_iso = 0.0;
    // (kept below 3: larger values make R close to the identity, a plateau)
    for (double lb = set.lb_lo + 1.0; lb <= std::min(3.0, set.lb_hi); lb += 1.0) {
      th.head(p).setConstant(lb);
      th.tail(p).setConstant(0.5);
      const double v = lik.eval(th, nug, nullptr, set.rcond_fail);
      if (v > best_iso) { best_iso = v; lb_iso = lb; }
    }
    if (!std::isfinite(best_iso)) continue;
    GaspFit fit;
    fit.nugget = nug;
    for (int s = 0; s < std::max(1, n_starts); ++s) {
      Eigen::VectorXd x0(2 * p);
      if (s == 0) {
        x0.head(p).setConstant(lb_iso);
        x0.tail(p).setConstant(0.5);
      } else {
        for (int q = 0; q < p; ++q) {
          x0(q) = -4.0 + 6.0 * halton(s, primes[q % n_primes]);  // log beta in [-4, 2]
          x0(p + q) = halton(s, primes[(p + q) % n_primes]);
        }
      }
      GaspSettings short_set = set;
      short_set.maxit = std::min(set.maxit_explore, set.maxit);
      GaspOptResult r = gasp_optimise(lik, x0, nug, lo, hi, short_set);
      if (r.loglik > fit.loglik) {
        fit.loglik = r.loglik;
        fit.theta = r.theta;
        fit.converged = r.converged;
      }
    }
    if (!std::isfinite(fit.loglik)) continue;
    if (!fit.converged) {
      GaspOptResult r = gasp_optimise(lik, fit.theta, nug, lo, hi, set);
      if (r.loglik >= fit.loglik) {
        fit.loglik = r.loglik;
        fit.theta = r.theta;
        fit.converged = r.converged;
      }
    }
    lik.eval(fit.theta, nug, nullptr, 0.0);
    best = fit;
    if (lik.rcond() >= set.rcond_ok) break;
  }
  best.n_eval = lik.n_eval;
  return best;
}

// Quantities of a fitted emulator at given (beta, alpha, nugget): mu, lambda,
// weights R^-1 (y - mu), lower Cholesky factor and log-likelihood. If R is not
// positive definite at `nugget`, the nugget is increased along the ladder.
struct GaspFinal {
  double mu = 0.0, lambda = 0.0, nugget = 0.0, loglik = 0.0;
  Eigen::VectorXd weights;
  Eigen::MatrixXd L;
  bool ok = false;
};

inline GaspFinal gasp_finalize(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                               const Eigen::VectorXd& beta, const Eigen::VectorXd& alpha,
                               double nugget) {
  const int K = static_cast<int>(X.rows()), p = static_cast<int>(X.cols());
  GaspFinal out;
  Eigen::MatrixXd R(K, K);
  for (int k = 0; k < K; ++k) {
    R(k, k) = 1.0;
    for (int j = k + 1; j < K; ++j) {
      double s = 0.0;
      for (int q = 0; q < p; ++q) {
        if (beta(q) == 0.0) continue;
        const double d = std::abs(X(j, q) - X(k, q));
        if (d > 0.0) s += beta(q) * std::pow(d, 2.0 - alpha(q));
      }
      R(j, k) = R(k, j) = std::exp(-s);
    }
  }
  static const double ladder[] = {1e-8, 1e-6, 1e-4, 1e-2, 1.0};
  std::vector<double> tries(1, nugget);
  for (double g : ladder) if (g > nugget) tries.push_back(g);
  Eigen::LLT<Eigen::MatrixXd> llt;
  for (double g : tries) {
    Eigen::MatrixXd Rg = R;
    Rg.diagonal().array() += g;
    llt.compute(Rg);
    if (llt.info() == Eigen::Success && llt.rcond() >= 1e-15) {
      out.nugget = g;
      out.ok = true;
      break;
    }
  }
  if (!out.ok) return out;
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(K);
  const Eigen::VectorXd a = llt.solve(ones), b = llt.solve(y);
  out.mu = ones.dot(b) / ones.dot(a);
  out.weights = b - out.mu * a;
  const double s2 = (y.array() - out.mu).matrix().dot(out.weights) / K;
  out.lambda = 1.0 / s2;
  out.L = llt.matrixL();
  double logdet = 0.0;
  for (int k = 0; k < K; ++k) logdet += std::log(out.L(k, k));
  out.loglik = -0.5 * K * std::log(2.0 * M_PI * s2) - logdet - 0.5 * K;
  return out;
}

}  // namespace wavevalid

#endif
