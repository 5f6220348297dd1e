// Maximisation of the GASP profile log-likelihood (gasp_lik.h): a projected
// limited-memory BFGS on the box log beta in [lb_lo, lb_hi], alpha in [0, 1],
// with its settings. Free of R types.
#ifndef WAVEVALID_GASP_OPTIM_H
#define WAVEVALID_GASP_OPTIM_H

#include <Eigen/Dense>
#include <vector>
#include <deque>
#include <cmath>
#include <limits>
#include <algorithm>
#include "gasp_lik.h"

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
  double alpha_lo = 0.0;     // box of alpha (the exponent is 2 - alpha)
  double alpha_hi = 1.0;
};

struct GaspOptResult {
  Eigen::VectorXd theta;
  double loglik = -std::numeric_limits<double>::infinity();
  int iterations = 0;
  bool converged = false;
};

// Projected L-BFGS maximising the profile log-likelihood on the box [lo, hi].
// Stops when the projected gradient is below pgtol or the objective changed
// by less than ftol * max(1, |loglik|) in two successive iterations. `Lik`
// is GaspLik (one coefficient) or GaspLevelLik (gasp_level.h, a level).
template <class Lik>
GaspOptResult gasp_optimise(Lik& lik, Eigen::VectorXd x, double nugget,
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

}  // namespace wavevalid

#endif
