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
#include <cstdint>
#include <utility>

namespace wavevalid {

struct GaspSettings {
  double lb_lo = -8.0;       // lower bound of log beta
  double lb_hi = 6.0;        // upper bound of log beta
  int maxit = 200;           // iterations of each local optimisation
  int n_local = 1;           // local optimisations, from the best screened points
  int n_screen = 8;          // space-filling screening points
  double screen_lo = -6.0;   // log beta range of the screening points
  double screen_hi = 2.0;
  double pgtol = 1e-5;       // projected-gradient tolerance
  double ftol = 1e-8;        // change of the objective (per unit of |loglik|)
  double rcond_fail = 1e-14; // below: the point counts as numerically singular
  double rcond_ok = 1e-12;   // below at the optimum: retry with a larger nugget
  int memory = 30;           // L-BFGS memory
  int gauss_first = 0;       // 1: optimise with alpha = 0 first, then free alpha
  int precondition = 1;      // 1: 2 x 2 preconditioner per input in L-BFGS
  int iso_half = 0;          // 1: isotropic screening points also at alpha = 0.5
};

// Pairwise |d| and log|d| per input of a scaled design over the K(K-1)/2
// pairs j > k (k-major), computed once per design and shared by the fits of
// all coefficients.
struct GaspDist {
  int K = 0, p = 0, P = 0;
  Eigen::MatrixXd logd, d1, d2;  // P x p
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
class GaspLik {
 public:
  GaspLik(const GaspDist& D, const Eigen::VectorXd& y) : D_(D), y_(y) {
    K_ = D.K;
    p_ = D.p;
    P_ = D.P;
    T_.resize(P_, p_);
    S_.resize(P_);
    R_.resize(K_, K_);
    Linv_.resize(K_, K_);
    Ri_.resize(K_, K_);
    Mp_.resize(P_);
    ones_ = Eigen::VectorXd::Ones(K_);
  }

  int n_runs() const { return K_; }
  int n_inputs() const { return p_; }
  const GaspDist& dist() const { return D_; }
  int n_eval = 0, n_grad = 0;

  // Fills R (correlation + nugget) for theta; keeps T_ = beta d^(2 - alpha) per pair.
  void build(const Eigen::VectorXd& theta, double nugget) {
    S_.setZero();
    for (int q = 0; q < p_; ++q) {
      const double lb = theta(q);
      const double a = theta(p_ + q);
      if (a == 0.0) {
        T_.col(q).noalias() = std::exp(lb) * D_.d2.col(q);
      } else if (a == 1.0) {
        T_.col(q).noalias() = std::exp(lb) * D_.d1.col(q);
      } else {
        T_.col(q) = ((2.0 - a) * D_.logd.col(q).array() + lb).exp().matrix();
      }
      S_ += T_.col(q).array();
    }
    C_ = (-S_).exp();
    int idx = 0;
    for (int k = 0; k < K_; ++k) {
      R_(k, k) = 1.0 + nugget;
      for (int j = k + 1; j < K_; ++j) R_(j, k) = C_(idx++);
    }
  }

  // Profile log-likelihood at theta; -inf when R is numerically singular.
  double value(const Eigen::VectorXd& theta, double nugget, double rcond_fail) {
    ++n_eval;
    ok_ = false;
    build(theta, nugget);
    llt_.compute(R_);  // reads the lower triangle only
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
    ok_ = true;
    return -0.5 * K_ * std::log(2.0 * M_PI * s2) - 0.5 * logdet - 0.5 * K_;
  }

  // Gradient in (log beta, alpha) at the point of the last successful value():
  //   dl/dtheta = 1/2 tr[(u u' / s2 - R^-1) dR/dtheta], dR_jk = -C_jk dS_jk.
  void gradient(Eigen::VectorXd& grad) {
    ++n_grad;
    grad.resize(2 * p_);
    // R^-1 = L^-T L^-1 (lower triangle) from the Cholesky factor, using the
    // triangular structure of both factors (K^3 / 3 flops in all)
    const Eigen::MatrixXd& L = llt_.matrixLLT();
    Linv_.setZero();
    for (int j = 0; j < K_; ++j) {  // column j of L^-1: forward substitution from e_j
      Linv_(j, j) = 1.0;
      for (int k = j; k < K_; ++k) {
        const double xk = Linv_(k, j) / L(k, k);
        Linv_(k, j) = xk;
        const int rest = K_ - k - 1;
        if (rest > 0) Linv_.col(j).segment(k + 1, rest) -= xk * L.col(k).segment(k + 1, rest);
      }
    }
    for (int k = 0; k < K_; ++k) {
      for (int j = k; j < K_; ++j) {
        Ri_(j, k) = Linv_.col(j).segment(j, K_ - j).dot(Linv_.col(k).segment(j, K_ - j));
      }
    }
    int idx = 0;
    const double is2 = 1.0 / sigma2_;
    for (int k = 0; k < K_; ++k) {
      const double uk = u_(k) * is2;
      for (int j = k + 1; j < K_; ++j) {
        Mp_(idx) = (u_(j) * uk - Ri_(j, k)) * C_(idx);  // factor 2 (symmetry) times 1/2
        ++idx;
      }
    }
    for (int q = 0; q < p_; ++q) {
      const Eigen::ArrayXd mt = Mp_ * T_.col(q).array();
      grad(q) = -mt.sum();
      grad(p_ + q) = (mt * D_.logd.col(q).array().max(-745.0)).sum();
    }
  }

  double eval(const Eigen::VectorXd& theta, double nugget, Eigen::VectorXd* grad, double rcond_fail) {
    const double ll = value(theta, nugget, rcond_fail);
    if (grad && std::isfinite(ll)) gradient(*grad);
    return ll;
  }

  double mu() const { return mu_; }
  double sigma2() const { return sigma2_; }
  double rcond() const { return rcond_; }

 private:
  const GaspDist& D_;
  Eigen::VectorXd y_;
  int K_, p_, P_;
  Eigen::MatrixXd T_, R_, Linv_, Ri_;
  Eigen::ArrayXd S_, C_, Mp_;
  Eigen::VectorXd ones_, u_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  double mu_ = 0.0, sigma2_ = 0.0, rcond_ = 0.0;
  bool ok_ = false;
};

struct GaspOptResult {
  Eigen::VectorXd theta;
  double loglik = -std::numeric_limits<double>::infinity();
  int iterations = 0;
  bool converged = false;
};

// Projected L-BFGS maximising the profile log-likelihood on the box [lo, hi].
// Stops when the projected gradient is below pgtol or the objective changed
// by less than ftol * max(1, |loglik|) in two successive iterations.
inline GaspOptResult gasp_optimise(GaspLik& lik, Eigen::VectorXd x, double nugget,
                                   const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                                   const GaspSettings& set) {
  const int n = static_cast<int>(x.size());
  const int p = lik.n_inputs();
  // Initial inverse Hessian of the two-loop recursion: per input, the inverse
  // of the 2 x 2 Gram matrix of (1, -log|d|) over the pairs, which undoes the
  // near-collinearity of log beta and alpha (beta d^(2 - alpha)).
  const Eigen::VectorXd& cm = lik.dist().c;
  const Eigen::VectorXd& vm = lik.dist().v;
  auto apply_h0 = [&](const Eigen::VectorXd& z) {
    Eigen::VectorXd out(n);
    for (int i = 0; i < p; ++i) {
      const double a = z(i), b = z(p + i), c = cm(i), v = vm(i);
      out(i) = ((c * c + v) * a + c * b) / v;
      out(p + i) = (c * a + b) / v;
    }
    return out;
  };
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
    Eigen::VectorXd d;
    if (set.precondition && n == 2 * p) {
      if (m > 0) gamma = S[m - 1].dot(Y[m - 1]) / Y[m - 1].dot(apply_h0(Y[m - 1]));
      d = gamma * apply_h0(q);
      for (int i = 0; i < n; ++i) if (!fr(i)) d(i) = 0.0;
    } else {
      if (m > 0) gamma = S[m - 1].dot(Y[m - 1]) / Y[m - 1].squaredNorm();
      d = gamma * q;
    }
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
    // backtracking Armijo search along the projected path; the gradient is
    // computed only at the accepted point
    double step = 1.0, f_new = std::numeric_limits<double>::infinity();
    Eigen::VectorXd x_new(n);
    bool ok = false;
    for (int ls = 0; ls < 40; ++ls) {
      x_new = (x + step * d).cwiseMax(lo).cwiseMin(hi);
      f_new = -lik.value(x_new, nugget, set.rcond_fail);
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
    lik.gradient(g_new);
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

// Space-filling screening points (columns: log beta_1..p, alpha_1..p): a
// Latin hypercube from a fixed-seed generator (splitmix64), so the same on
// every platform and for every coefficient. Log beta in [screen_lo,
// screen_hi]; alpha in [0, 1], with the lowest quarter of each alpha
// stratum set to 0 (the Gaussian end, where most optima lie).
inline Eigen::MatrixXd gasp_screen_points(int p, const GaspSettings& set) {
  const int n = std::max(0, set.n_screen);
  Eigen::MatrixXd pts(2 * p, n);
  if (n == 0) return pts;
  uint64_t state = 0x9e3779b97f4a7c15ULL;
  auto next = [&state]() {
    uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z = z ^ (z >> 31);
    return static_cast<double>(z >> 11) / 9007199254740992.0;  // 2^53
  };
  std::vector<int> perm(n);
  for (int r = 0; r < 2 * p; ++r) {
    for (int i = 0; i < n; ++i) perm[i] = i;
    for (int i = n - 1; i > 0; --i) {  // Fisher-Yates
      const int j = static_cast<int>(next() * (i + 1));
      std::swap(perm[i], perm[std::min(j, i)]);
    }
    for (int i = 0; i < n; ++i) {
      const double v = (perm[i] + next()) / n;
      if (r < p) {
        pts(r, i) = set.screen_lo + (set.screen_hi - set.screen_lo) * v;
      } else {
        pts(r, i) = v < 0.25 ? 0.0 : (v - 0.25) / 0.75;
      }
    }
  }
  return pts;
}

struct GaspFit {
  Eigen::VectorXd theta;  // (log beta, alpha)
  double nugget = 0.0;
  double loglik = -std::numeric_limits<double>::infinity();
  int n_eval = 0, n_grad = 0;
  bool converged = false;
};

// Fits one coefficient. Screening: the likelihood (no gradient) at the warm
// starts (fitted parameters of related coefficients), at isotropic points
// (common log beta on a grid, alpha 0 and 0.5) and at the space-filling
// points `screen` (2p x n). Then projected L-BFGS from the best n_local
// distinct screened points; the best result is kept. The nugget is increased
// along a ladder while the optimum is numerically singular.
inline GaspFit gasp_fit(const GaspDist& D, const Eigen::VectorXd& y,
                        const std::vector<Eigen::VectorXd>& warm, const Eigen::MatrixXd& screen,
                        const GaspSettings& set) {
  static const double ladder[] = {0.0, 1e-8, 1e-6, 1e-4, 1e-2};
  GaspLik lik(D, y);
  const int p = lik.n_inputs();
  Eigen::VectorXd lo(2 * p), hi(2 * p);
  lo.head(p).setConstant(set.lb_lo); hi.head(p).setConstant(set.lb_hi);
  lo.tail(p).setZero(); hi.tail(p).setOnes();
  std::vector<Eigen::VectorXd> cand;
  for (const Eigen::VectorXd& w : warm) {
    if (w.size() == 2 * p && w.allFinite()) cand.push_back(w.cwiseMax(lo).cwiseMin(hi));
  }
  // (common log beta kept below 3: larger values make R close to the identity, a plateau)
  for (double a : {0.0, 0.5}) {
    if (a > 0.0 && !set.iso_half) continue;
    for (double lb = set.lb_lo + 1.0; lb <= std::min(3.0, set.lb_hi); lb += 1.0) {
      Eigen::VectorXd th(2 * p);
      th.head(p).setConstant(lb);
      th.tail(p).setConstant(a);
      cand.push_back(th);
    }
  }
  for (int i = 0; i < screen.cols(); ++i) cand.push_back(screen.col(i).cwiseMax(lo).cwiseMin(hi));
  const int nc = static_cast<int>(cand.size());
  GaspFit best;
  for (double nug : ladder) {
    std::vector<std::pair<double, int>> scored;
    for (int i = 0; i < nc; ++i) {
      const double v = lik.value(cand[i], nug, set.rcond_fail);
      if (std::isfinite(v)) scored.emplace_back(-v, i);
    }
    if (scored.empty()) continue;
    std::stable_sort(scored.begin(), scored.end(),
                     [](const std::pair<double, int>& a, const std::pair<double, int>& b) {
                       return a.first < b.first;
                     });
    GaspFit fit;
    fit.nugget = nug;
    std::vector<Eigen::VectorXd> done;
    for (const auto& sc : scored) {
      if (static_cast<int>(done.size()) >= std::max(1, set.n_local)) break;
      const Eigen::VectorXd& x0 = cand[sc.second];
      bool dup = false;
      for (const Eigen::VectorXd& d : done) dup = dup || (d - x0).lpNorm<Eigen::Infinity>() < 1e-6;
      if (dup) continue;
      done.push_back(x0);
      Eigen::VectorXd x1 = x0;
      if (set.gauss_first) {
        Eigen::VectorXd hi0 = hi;
        hi0.tail(p).setZero();
        x1.tail(p).setZero();
        x1 = gasp_optimise(lik, x1, nug, lo, hi0, set).theta;
      }
      GaspOptResult r = gasp_optimise(lik, x1, nug, lo, hi, set);
      if (r.loglik > fit.loglik) {
        fit.loglik = r.loglik;
        fit.theta = r.theta;
        fit.converged = r.converged;
      }
    }
    if (!std::isfinite(fit.loglik)) continue;
    lik.value(fit.theta, nug, 0.0);
    best = fit;
    if (lik.rcond() >= set.rcond_ok) break;
  }
  best.n_eval = lik.n_eval;
  best.n_grad = lik.n_grad;
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
