// The statistics of one block of curve draws for the bands (bands.cpp): the
// pointwise mean and spread, the type-7 quantiles, each draw's largest
// standardised distance from the mean and the envelope's candidates, free of
// R's objects so that a block's time points can be shared among threads
// (band_block_into_cpp()).
#ifndef WAVEVALID_BAND_STATS_H
#define WAVEVALID_BAND_STATS_H

#include <Rcpp.h>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

namespace wavevalid {

struct ProbPositions {
  std::vector<int> lo, hi, need;  // 1-based order statistics; need: both, ascending, unique
  std::vector<double> f;
  ProbPositions(const std::vector<double>& probs, int H) : lo(probs.size()), hi(probs.size()), f(probs.size()) {
    for (std::size_t j = 0; j < probs.size(); ++j) {
      const double pos = 1 + (H - 1) * probs[j];
      lo[j] = static_cast<int>(std::floor(pos));
      hi[j] = static_cast<int>(std::ceil(pos));
      f[j] = pos - lo[j];
    }
    need = lo;
    need.insert(need.end(), hi.begin(), hi.end());
    std::sort(need.begin(), need.end());
    need.erase(std::unique(need.begin(), need.end()), need.end());
  }
};

typedef std::pair<double, int> ValueDraw;

inline bool value_less(const ValueDraw& a, const ValueDraw& b) { return a.first < b.first; }

inline bool value_greater(const ValueDraw& a, const ValueDraw& b) { return a.first > b.first; }

// The k draws of y (length H) that come first by `before` (value_less: the
// smallest; value_greater: the largest) into sel[0 .. k), in no particular
// order (sel[k - 1] the k-th). A threshold from a strided sample of the
// values keeps the draws that may be among them (one pass without branches),
// and the selection is made among those; when the threshold keeps fewer than
// k (it is set with a wide margin), among all draws.
template <class Before>
inline void select_first(const double* y, int H, int k, Before before, std::vector<ValueDraw>& sel,
                  std::vector<double>& sample) {
  sel.resize(H);
  const bool low = before(ValueDraw(0.0, 0), ValueDraw(1.0, 0));
  int n = H;
  const int S = std::min(H, 256);
  const double p = static_cast<double>(k) / H;
  const int r = static_cast<int>(std::ceil(S * p + 4.0 * std::sqrt(S * p * (1 - p)) + 4.0));
  if (H >= 1024 && r < S - 1) {
    sample.resize(S);
    for (int i = 0; i < S; ++i) sample[i] = y[static_cast<std::ptrdiff_t>(i) * H / S];
    double thr;
    if (low) {
      std::nth_element(sample.begin(), sample.begin() + r, sample.end());
      thr = sample[r];
    } else {
      std::nth_element(sample.begin(), sample.begin() + r, sample.end(), std::greater<double>());
      thr = sample[r];
    }
    int c = 0;
    if (low) {
      for (int h = 0; h < H; ++h) {
        sel[c] = ValueDraw(y[h], h);
        c += y[h] <= thr;
      }
    } else {
      for (int h = 0; h < H; ++h) {
        sel[c] = ValueDraw(y[h], h);
        c += y[h] >= thr;
      }
    }
    n = c >= k ? c : H;
    if (c < k) {
      for (int h = 0; h < H; ++h) sel[h] = ValueDraw(y[h], h);
    }
  } else {
    for (int h = 0; h < H; ++h) sel[h] = ValueDraw(y[h], h);
  }
  if (k < n) std::nth_element(sel.begin(), sel.begin() + (k - 1), sel.begin() + n, before);
}

// Statistics of one block of curve draws (see band_block_cpp()), Y column-major
// H x m.
// Where block_stats() writes: the outputs of all time points (mean, ss:
// length n; q: np x n; lo_val, lo_idx, hi_val, hi_idx: n_cand x n, column
// major), the block's first time point at column `off`.
struct BlockOut {
  double *mean, *ss, *q, *lo_val, *hi_val;
  int *lo_idx, *hi_idx;
  int off;
};

// block_stats() without R: each draw's largest distance into zmax (H values,
// raised where larger), the smallest spread into smin; false (the outputs
// partly written) when the draws hold NaN. `interrupts`: whether to check
// for a user interrupt every 256 time points (only on R's own thread).
inline bool block_stats_core(const double* Y, int H, int m, const ProbPositions& pp, int np, int n_cand,
                      const BlockOut& o, bool scores, double* zmax_out, double& smin_out, bool interrupts) {
  n_cand = std::max(0, std::min(n_cand, H));
  auto mean = [&](int j) -> double& { return o.mean[o.off + j]; };
  auto ss = [&](int j) -> double& { return o.ss[o.off + j]; };
  auto q = [&](int p, int j) -> double& { return o.q[static_cast<std::ptrdiff_t>(o.off + j) * np + p]; };
  auto lo_val = [&](int k, int j) -> double& { return o.lo_val[static_cast<std::ptrdiff_t>(o.off + j) * n_cand + k]; };
  auto hi_val = [&](int k, int j) -> double& { return o.hi_val[static_cast<std::ptrdiff_t>(o.off + j) * n_cand + k]; };
  auto lo_idx = [&](int k, int j) -> int& { return o.lo_idx[static_cast<std::ptrdiff_t>(o.off + j) * n_cand + k]; };
  auto hi_idx = [&](int k, int j) -> int& { return o.hi_idx[static_cast<std::ptrdiff_t>(o.off + j) * n_cand + k]; };
  double smin = std::numeric_limits<double>::infinity();
  std::vector<double> v(H), sample;
  std::vector<ValueDraw> pv(n_cand > 0 ? H : 0), sel_lo, sel_hi;
  // The order statistics at the low and high ends (quantiles and, with
  // candidates, the n_cand smallest and largest) are selected among the
  // k_lo smallest and the k_hi largest draws when these are few; otherwise
  // among all draws.
  int k_lo = n_cand, k_hi = n_cand;
  for (int k : pp.need) {
    if (2 * k <= H) k_lo = std::max(k_lo, k);
    else k_hi = std::max(k_hi, H - k + 1);
  }
  const bool ends = 4 * (k_lo + k_hi) <= H;
  const bool split = !ends && n_cand > 0 && 2 * n_cand <= H;
  const double denom = std::max(H - 1, 1);
  for (int j = 0; j < m; ++j) {
    const double* y = Y + static_cast<std::ptrdiff_t>(j) * H;
    // as colMeans() and colSums(): sums in long double
    long double sum = 0;
    for (int h = 0; h < H; ++h) {
      if (std::isnan(y[h])) return false;
      sum += y[h];
    }
    sum /= H;
    const double c = static_cast<double>(sum);
    long double sq = 0;
    for (int h = 0; h < H; ++h) {
      const double d = y[h] - c;
      sq += d * d;
    }
    mean(j) = c;
    ss(j) = static_cast<double>(sq);
    const double s = std::sqrt(ss(j) / denom);
    smin = std::min(smin, s);
    if (scores && s > 0) {
      double* zm = zmax_out;
      for (int h = 0; h < H; ++h) {
        const double z = std::fabs((y[h] - c) / s);
        if (z > zm[h]) zm[h] = z;
      }
    }
    if (ends) {
      if (k_lo > 0) select_first(y, H, k_lo, value_less, sel_lo, sample);
      if (k_hi > 0) select_first(y, H, k_hi, value_greater, sel_hi, sample);
      std::vector<double> os(pp.need.size());
      for (std::size_t i = 0; i < pp.need.size(); ++i) {
        const int k = pp.need[i];
        if (2 * k <= H) {
          std::nth_element(sel_lo.begin(), sel_lo.begin() + (k - 1), sel_lo.begin() + k_lo, value_less);
          os[i] = sel_lo[k - 1].first;
        } else {
          const int r = H - k;  // rank from the top, 0-based
          std::nth_element(sel_hi.begin(), sel_hi.begin() + r, sel_hi.begin() + k_hi, value_greater);
          os[i] = sel_hi[r].first;
        }
      }
      auto stat = [&](int k) {
        return os[std::lower_bound(pp.need.begin(), pp.need.end(), k) - pp.need.begin()];
      };
      for (int p = 0; p < np; ++p) q(p, j) = stat(pp.lo[p]) * (1 - pp.f[p]) + stat(pp.hi[p]) * pp.f[p];
      if (n_cand > 0) {
        if (n_cand < k_lo) std::nth_element(sel_lo.begin(), sel_lo.begin() + (n_cand - 1), sel_lo.begin() + k_lo, value_less);
        if (n_cand < k_hi) std::nth_element(sel_hi.begin(), sel_hi.begin() + (n_cand - 1), sel_hi.begin() + k_hi, value_greater);
        for (int k = 0; k < n_cand; ++k) {
          lo_val(k, j) = sel_lo[k].first;
          lo_idx(k, j) = sel_lo[k].second + 1;
          hi_val(k, j) = sel_hi[k].first;
          hi_idx(k, j) = sel_hi[k].second + 1;
        }
      }
    } else if (split) {
      for (int h = 0; h < H; ++h) pv[h] = ValueDraw(y[h], h);
      std::nth_element(pv.begin(), pv.begin() + (n_cand - 1), pv.end(), value_less);
      if (H - n_cand > n_cand) std::nth_element(pv.begin() + n_cand, pv.begin() + (H - n_cand), pv.end(), value_less);
      // bounds of the range of ranks holding order statistic k (0-based)
      int start = 0;
      for (int k1 : pp.need) {
        const int k = k1 - 1;
        const int lo_r = k < n_cand ? 0 : (k < H - n_cand ? n_cand : H - n_cand);
        const int hi_r = k < n_cand ? n_cand : (k < H - n_cand ? H - n_cand : H);
        const int from = std::max(start, lo_r);
        if (from <= k) std::nth_element(pv.begin() + from, pv.begin() + k, pv.begin() + hi_r, value_less);
        start = k + 1;
      }
      for (int p = 0; p < np; ++p)
        q(p, j) = pv[pp.lo[p] - 1].first * (1 - pp.f[p]) + pv[pp.hi[p] - 1].first * pp.f[p];
      for (int k = 0; k < n_cand; ++k) {
        lo_val(k, j) = pv[k].first;
        lo_idx(k, j) = pv[k].second + 1;
        hi_val(k, j) = pv[H - n_cand + k].first;
        hi_idx(k, j) = pv[H - n_cand + k].second + 1;
      }
    } else {
      if (np > 0) {
        std::copy(y, y + H, v.begin());
        auto start = v.begin();
        for (int k : pp.need) {
          std::nth_element(start, v.begin() + (k - 1), v.end());
          start = v.begin() + k;
        }
        for (int p = 0; p < np; ++p) q(p, j) = v[pp.lo[p] - 1] * (1 - pp.f[p]) + v[pp.hi[p] - 1] * pp.f[p];
      }
      if (n_cand > 0) {
        for (int h = 0; h < H; ++h) pv[h] = ValueDraw(y[h], h);
        if (n_cand < H) std::nth_element(pv.begin(), pv.begin() + (n_cand - 1), pv.end(), value_less);
        for (int k = 0; k < n_cand; ++k) {
          lo_val(k, j) = pv[k].first;
          lo_idx(k, j) = pv[k].second + 1;
        }
        if (n_cand < H) std::nth_element(pv.begin(), pv.begin() + (H - n_cand), pv.end(), value_less);
        for (int k = 0; k < n_cand; ++k) {
          hi_val(k, j) = pv[H - n_cand + k].first;
          hi_idx(k, j) = pv[H - n_cand + k].second + 1;
        }
      }
    }
    if (interrupts && j % 256 == 255) Rcpp::checkUserInterrupt();
  }
  smin_out = smin;
  return true;
}

}  // namespace wavevalid

#endif
