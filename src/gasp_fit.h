// Maximum-likelihood fitting of one GASP emulator coefficient: screening of
// deterministic starts (warm starts, isotropic points, a fixed-seed Latin
// hypercube), then the projected L-BFGS of gasp_optim.h from the best of them,
// with a nugget ladder while the optimum is numerically singular.
// Free of R types.
#ifndef WAVEVALID_GASP_FIT_H
#define WAVEVALID_GASP_FIT_H

#include <Eigen/Dense>
#include <vector>
#include <cmath>
#include <limits>
#include <algorithm>
#include <cstdint>
#include <utility>
#include "gasp_lik.h"
#include "gasp_optim.h"

namespace wavevalid {

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
// `Lik` is GaspLik (one coefficient) or GaspLevelLik (the coefficients of a
// level sharing theta, gasp_level.h).
template <class Lik>
GaspFit gasp_fit_lik(Lik& lik, const std::vector<Eigen::VectorXd>& warm, const Eigen::MatrixXd& screen,
                     const GaspSettings& set) {
  static const double ladder[] = {0.0, 1e-8, 1e-6, 1e-4, 1e-2};
  const int p = lik.n_inputs();
  Eigen::VectorXd lo(2 * p), hi(2 * p);
  lo.head(p).setConstant(set.lb_lo); hi.head(p).setConstant(set.lb_hi);
  lo.tail(p).setConstant(set.alpha_lo); hi.tail(p).setConstant(set.alpha_hi);
  std::vector<Eigen::VectorXd> cand;
  for (const Eigen::VectorXd& w : warm) {
    if (w.size() == 2 * p && w.allFinite()) cand.push_back(w.cwiseMax(lo).cwiseMin(hi));
  }
  // (common log beta kept below 3: larger values make R close to the identity, a plateau)
  for (double a : {set.alpha_lo, 0.5 * (set.alpha_lo + set.alpha_hi)}) {
    if (a > set.alpha_lo && !set.iso_half) continue;
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
        hi0.tail(p).setConstant(set.alpha_lo);
        x1.tail(p).setConstant(set.alpha_lo);
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

inline GaspFit gasp_fit(const GaspDist& D, const Eigen::VectorXd& y,
                        const std::vector<Eigen::VectorXd>& warm, const Eigen::MatrixXd& screen,
                        const GaspSettings& set) {
  GaspLik lik(D, y);
  return gasp_fit_lik(lik, warm, screen, set);
}

}  // namespace wavevalid

#endif
