// Curve summaries of the bands (R/predict-bands.R, R/fit-draws.R): curve draws rebuilt
// from coefficient draws block by block of time points, and the statistics of
// one block (band_stats.h: pointwise mean and spread, quantiles, each curve's
// largest standardised distance from the mean, and the candidates for the
// envelope of the simultaneous band), on one thread or several; and the
// export of misfit_check()'s scan (misfit_scan.h).
#include <RcppEigen.h>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <thread>
#include <vector>
#include "band_stats.h"
#include "misfit_scan.h"

// [[Rcpp::depends(RcppEigen)]]

namespace {

// Y (H x m) = W %*% t(Psi[cols, ]) (cols 1-based), from the columns of Psi
// that are not zero on these time points, in stretches of kChunk time points,
// each with the columns not zero on it: a wavelet of level l is not zero on
// about T / 2^l points, so a stretch meets a few wavelets of each level
// besides its share of the finest ones (at 8192 points and 3800 retained
// coefficients, about 60 of them in a stretch of 32 points, against all 3800
// in a stretch of a few thousand).
// With `add`, Y += W %*% t(Psi[cols, ]).
constexpr int kChunk = 32;

// The sizes and time points of block_product(), checked before it runs (it
// may run on a thread of its own, where R's errors cannot be raised).
void check_block_product(const Eigen::Map<Eigen::MatrixXd>& W, const Eigen::Map<Eigen::MatrixXd>& Psi,
                         const Rcpp::IntegerVector& cols) {
  if (Psi.cols() != W.cols()) Rcpp::stop("W and Psi need the same number of coefficients");
  for (int i = 0; i < cols.size(); ++i) {
    if (cols[i] < 1 || cols[i] > Psi.rows()) Rcpp::stop("time point out of range");
  }
}

// Y's m columns from the time points cols[0 .. m) (checked:
// check_block_product()); Y may be the middle columns of a larger block.
template <class Out>
void block_product(const Eigen::Map<Eigen::MatrixXd>& W, const Eigen::Map<Eigen::MatrixXd>& Psi,
                   const int* cols, int m, Out&& Y, bool add = false) {
  const int H = W.rows(), K = W.cols(), T = Psi.rows();
  if (H == 0 || m == 0) return;
  std::vector<int> active;
  active.reserve(K);
  Eigen::MatrixXd Pt, Wa;
  for (int c0 = 0; c0 < m; c0 += kChunk) {
    const int w = std::min(kChunk, m - c0);
    active.clear();
    for (int k = 0; k < K; ++k) {
      const double* p = Psi.data() + static_cast<std::ptrdiff_t>(k) * T;
      for (int i = c0; i < c0 + w; ++i) {
        if (p[cols[i] - 1] != 0.0) {
          active.push_back(k);
          break;
        }
      }
    }
    const int a = active.size();
    auto Yc = Y.middleCols(c0, w);
    if (a == 0) {
      if (!add) Yc.setZero();
      continue;
    }
    Pt.resize(a, w);
    for (int i = 0; i < w; ++i) {
      for (int j = 0; j < a; ++j) Pt(j, i) = Psi(cols[c0 + i] - 1, active[j]);
    }
    Wa.resize(H, a);
    for (int j = 0; j < a; ++j) Wa.col(j) = W.col(active[j]);
    if (add) Yc.noalias() += Wa * Pt; else Yc.noalias() = Wa * Pt;
  }
}

}  // namespace

// W %*% t(Psi[cols, ]): the curve draws (rows of W are coefficient draws) at
// the time points `cols` (1-based). Only the columns of Psi that are not zero
// on these time points enter the product: a wavelet of a fine level is zero
// outside a short stretch of the record, so a block of time points meets a
// small share of them.
// [[Rcpp::export]]
Rcpp::NumericMatrix basis_block_cpp(const Eigen::Map<Eigen::MatrixXd>& W, const Eigen::Map<Eigen::MatrixXd>& Psi,
                                    const Rcpp::IntegerVector& cols) {
  Rcpp::NumericMatrix out = Rcpp::no_init_matrix(W.rows(), cols.size());
  Eigen::Map<Eigen::MatrixXd> Y(out.begin(), W.rows(), cols.size());
  check_block_product(W, Psi, cols);
  block_product(W, Psi, cols.begin(), cols.size(), Y);
  return out;
}

namespace {

using wavevalid::BlockOut;
using wavevalid::ProbPositions;
using wavevalid::block_stats_core;

std::vector<double> probs_of(const Rcpp::NumericVector& probs) { return std::vector<double>(probs.begin(), probs.end()); }

Rcpp::List block_stats(const double* Y, int H, int m, const Rcpp::NumericVector& probs, int n_cand,
                       const BlockOut& o, bool scores = true) {
  if (H < 1) Rcpp::stop("no curve draws");
  const ProbPositions pp(probs_of(probs), H);
  Rcpp::NumericVector zmax(H, R_NegInf);
  double smin = R_PosInf;
  if (!block_stats_core(Y, H, m, pp, probs.size(), n_cand, o, scores, zmax.begin(), smin, true))
    Rcpp::stop("the curve draws hold NaN");
  return Rcpp::List::create(Rcpp::Named("zmax") = zmax, Rcpp::Named("smin") = smin);
}

// The buffer of the blocks rebuilt by band_block_into_cpp(), kept between
// calls.
std::vector<double>& block_buffer() {
  static std::vector<double> buf;
  return buf;
}

}  // namespace

// Statistics of one block of curve draws Y (H draws x m time points):
// `mean` and `ss` (sum of squared deviations from it) at each time point,
// as colMeans() and colSums() compute them; the type-7 quantiles `q` at
// `probs`; `zmax`, each draw's largest |Y - mean| / sd over the block's time
// points whose sd is not zero (sd = sqrt(ss / (H - 1))), and `smin`, the
// smallest sd; with n_cand > 0, the n_cand smallest and largest values at
// each time point and their draws (1-based): `lo_val`, `lo_idx`, `hi_val`,
// `hi_idx` (n_cand x m), enough for the envelope of all draws but at most
// n_cand - 1 of them.
// [[Rcpp::export]]
Rcpp::List band_block_cpp(const Rcpp::NumericMatrix& Y, const Rcpp::NumericVector& probs, int n_cand) {
  const int H = Y.nrow(), m = Y.ncol();
  n_cand = std::max(0, std::min(n_cand, H));
  Rcpp::NumericVector mean(m), ss(m);
  Rcpp::NumericMatrix q(probs.size(), m), lo_val(n_cand, m), hi_val(n_cand, m);
  Rcpp::IntegerMatrix lo_idx(n_cand, m), hi_idx(n_cand, m);
  const BlockOut o{mean.begin(), ss.begin(), q.begin(), lo_val.begin(), hi_val.begin(), lo_idx.begin(), hi_idx.begin(), 0};
  Rcpp::List st = block_stats(Y.begin(), H, m, probs, n_cand, o);
  return Rcpp::List::create(Rcpp::Named("mean") = mean, Rcpp::Named("ss") = ss, Rcpp::Named("q") = q,
                            Rcpp::Named("zmax") = st["zmax"], Rcpp::Named("smin") = st["smin"],
                            Rcpp::Named("lo_val") = lo_val, Rcpp::Named("lo_idx") = lo_idx,
                            Rcpp::Named("hi_val") = hi_val, Rcpp::Named("hi_idx") = hi_idx);
}

namespace {

// The outputs `out` (a list made by curve_bands(): mean, ss, q, lo_val,
// lo_idx, hi_val, hi_idx for all n time points) as a BlockOut at column
// `off`, after checking their sizes.
BlockOut block_out(const Rcpp::List& out, int off, int m, int np, int n_cand) {
  Rcpp::NumericVector mean = out["mean"], ss = out["ss"];
  Rcpp::NumericMatrix q = out["q"], lo_val = out["lo_val"], hi_val = out["hi_val"];
  Rcpp::IntegerMatrix lo_idx = out["lo_idx"], hi_idx = out["hi_idx"];
  const int n = mean.size();
  if (off < 0 || off + m > n || ss.size() != n || q.nrow() != np || q.ncol() != n || lo_val.nrow() != n_cand ||
      lo_val.ncol() != n || hi_val.nrow() != n_cand || hi_val.ncol() != n || lo_idx.nrow() != n_cand ||
      lo_idx.ncol() != n || hi_idx.nrow() != n_cand || hi_idx.ncol() != n) {
    Rcpp::stop("the outputs of the block statistics have the wrong sizes");
  }
  return BlockOut{mean.begin(), ss.begin(), q.begin(), lo_val.begin(), hi_val.begin(), lo_idx.begin(),
                  hi_idx.begin(), off};
}

}  // namespace

// As band_block_cpp(), written into `out` (see block_out()) at the columns
// of the block, which starts at time point off + 1; returns zmax and smin.
// The block is Y, or, when Y has no rows, W %*% t(B[cols, ]) (plus
// W2 %*% t(B2[cols, ]) when W2 has rows) + offset[cols] (each draw), rebuilt
// in a buffer kept between calls (see basis_block_cpp()). `out`'s vectors are written in place: curve_bands()
// makes them for this alone. With `threads` above 1 the block's time points
// are shared out among that many threads in stretches of whole kChunk
// points (each rebuilt and summarised as alone; each draw's largest
// distance the largest of the threads'): the same numbers to the bit.
// [[Rcpp::export]]
Rcpp::List band_block_into_cpp(const Rcpp::NumericMatrix& Y, const Eigen::Map<Eigen::MatrixXd>& W,
                               const Eigen::Map<Eigen::MatrixXd>& B, const Eigen::Map<Eigen::MatrixXd>& W2,
                               const Eigen::Map<Eigen::MatrixXd>& B2, const Rcpp::IntegerVector& cols,
                               const Rcpp::NumericVector& offset, const Rcpp::NumericVector& probs, int n_cand,
                               const Rcpp::List& out, bool scores = true, int threads = 1) {
  const int m = cols.size();
  if (m < 1) Rcpp::stop("an empty block");
  for (int i = 1; i < m; ++i) {
    if (cols[i] != cols[0] + i) Rcpp::stop("the time points of a block must be consecutive");
  }
  const int off = cols[0] - 1;
  const bool given = Y.nrow() > 0;
  if (given && Y.ncol() != m) Rcpp::stop("one column of Y per time point");
  const int H = given ? Y.nrow() : W.rows();
  if (H < 1) Rcpp::stop("no curve draws");
  const int nc = std::max(0, std::min(n_cand, H));
  const BlockOut o = block_out(out, off, m, probs.size(), nc);
  const bool second = !given && W2.rows() > 0;
  if (!given) {
    check_block_product(W, B, cols);
    if (second) {
      if (W2.rows() != H || B2.rows() != B.rows()) Rcpp::stop("the second term has the wrong sizes");
      check_block_product(W2, B2, cols);
    }
    if (offset.size() > 0 && offset.size() != B.rows()) Rcpp::stop("one offset per time point");
  }
  const double* data = given ? Y.begin() : nullptr;
  if (!given) {
    std::vector<double>& buf = block_buffer();
    buf.resize(static_cast<std::size_t>(H) * m);
    data = buf.data();
  }
  const std::vector<double> pv = probs_of(probs);
  const ProbPositions pp(pv, H);
  const int np = probs.size();
  const double* off_v = offset.size() > 0 ? offset.begin() : nullptr;
  // time points [a, b) of the block: rebuilt (unless given) and summarised
  auto part = [&](int a, int b, double* zmax, double& smin, bool main) {
    if (!given) {
      double* y = const_cast<double*>(data) + static_cast<std::ptrdiff_t>(a) * H;
      Eigen::Map<Eigen::MatrixXd> Yb(y, H, b - a);
      block_product(W, B, cols.begin() + a, b - a, Yb);
      if (second) block_product(W2, B2, cols.begin() + a, b - a, Yb, true);
      if (off_v) {
        for (int i = a; i < b; ++i) Yb.col(i - a).array() += off_v[cols[i] - 1];
      }
    }
    BlockOut oa = o;
    oa.off = o.off + a;
    return block_stats_core(data + static_cast<std::ptrdiff_t>(a) * H, H, b - a, pp, np, nc, oa, scores, zmax, smin,
                            main);
  };
  const int stretches = (m + kChunk - 1) / kChunk;
  const int T = std::max(1, std::min(threads, stretches));
  Rcpp::NumericVector zmax(H, R_NegInf);
  double smin = R_PosInf;
  bool ok = true;
  if (T == 1) {
    ok = part(0, m, zmax.begin(), smin, true);
  } else {
    // thread t takes the stretches [t * per, (t + 1) * per), the first on R's own thread
    const int per = (stretches + T - 1) / T;
    std::vector<std::vector<double>> zm(T, std::vector<double>(H, -std::numeric_limits<double>::infinity()));
    std::vector<double> sm(T, std::numeric_limits<double>::infinity());
    std::vector<char> good(T, 1);
    auto run = [&](int t) {
      const int a = std::min(m, t * per * kChunk), b = std::min(m, (t + 1) * per * kChunk);
      try {
        if (a < b) good[t] = part(a, b, zm[t].data(), sm[t], false);
      } catch (...) {
        good[t] = 2;  // out of memory: reported below, on R's thread
      }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < T; ++t) {
      // a thread that cannot be started: its stretches on this one
      try {
        pool.emplace_back(run, t);
      } catch (...) {
        run(t);
      }
    }
    run(0);
    for (std::thread& th : pool) th.join();
    for (int t = 0; t < T; ++t) {
      if (good[t] == 2) Rcpp::stop("a thread summarising the curve draws failed (out of memory?)");
      ok = ok && good[t];
      smin = std::min(smin, sm[t]);
      double* z = zmax.begin();
      for (int h = 0; h < H; ++h) z[h] = std::max(z[h], zm[t][h]);
    }
  }
  if (!ok) Rcpp::stop("the curve draws hold NaN");
  return Rcpp::List::create(Rcpp::Named("zmax") = zmax, Rcpp::Named("smin") = smin);
}

// The outputs of band_block_into_cpp() for n time points, np quantiles and
// nc candidates at each end, not initialised (the blocks fill every column).
// [[Rcpp::export]]
Rcpp::List band_outputs_cpp(int n, int np, int nc) {
  return Rcpp::List::create(
      Rcpp::Named("mean") = Rcpp::NumericVector(Rcpp::no_init(n)),
      Rcpp::Named("ss") = Rcpp::NumericVector(Rcpp::no_init(n)),
      Rcpp::Named("q") = Rcpp::NumericMatrix(Rcpp::no_init(np, n)),
      Rcpp::Named("lo_val") = Rcpp::NumericMatrix(Rcpp::no_init(nc, n)),
      Rcpp::Named("lo_idx") = Rcpp::IntegerMatrix(Rcpp::no_init(nc, n)),
      Rcpp::Named("hi_val") = Rcpp::NumericMatrix(Rcpp::no_init(nc, n)),
      Rcpp::Named("hi_idx") = Rcpp::IntegerMatrix(Rcpp::no_init(nc, n)));
}

// Frees the buffer of band_block_into_cpp().
// [[Rcpp::export]]
void band_block_release_cpp() {
  std::vector<double>().swap(block_buffer());
}

// Each draw's largest |Y - centre| / s over the block's time points (s > 0).
// [[Rcpp::export]]
Rcpp::NumericVector band_score_cpp(const Rcpp::NumericMatrix& Y, const Rcpp::NumericVector& centre,
                                   const Rcpp::NumericVector& s) {
  const int H = Y.nrow(), m = Y.ncol();
  if (centre.size() != m || s.size() != m) Rcpp::stop("one centre and spread per time point");
  Rcpp::NumericVector out(H, R_NegInf);
  for (int j = 0; j < m; ++j) {
    const double* y = &Y(0, j);
    for (int h = 0; h < H; ++h) {
      const double z = std::fabs((y[h] - centre[j]) / s[j]);
      if (z > out[h]) out[h] = z;
    }
  }
  return out;
}

// Envelope (lower: the minimum, else the maximum) at each time point of the
// draws not `dropped`, from candidate values and their draws (as
// band_block_cpp() gives them) or, with idx empty, from a block of all draws.
// [[Rcpp::export]]
Rcpp::NumericVector band_envelope_cpp(const Rcpp::NumericMatrix& val, const Rcpp::IntegerMatrix& idx,
                                      const Rcpp::LogicalVector& dropped, bool lower) {
  const int n = val.nrow(), m = val.ncol();
  const bool all = idx.nrow() == 0;
  if (!all && (idx.nrow() != n || idx.ncol() != m)) Rcpp::stop("one draw per candidate value");
  if (all && dropped.size() != n) Rcpp::stop("one flag per draw");
  Rcpp::NumericVector out(m, NA_REAL);
  for (int j = 0; j < m; ++j) {
    bool found = false;
    double e = 0;
    for (int k = 0; k < n; ++k) {
      const int h = all ? k : idx(k, j) - 1;
      if (h < 0 || h >= dropped.size()) Rcpp::stop("draw out of range");
      if (dropped[h]) continue;
      const double x = val(k, j);
      if (!found || (lower ? x < e : x > e)) e = x;
      found = true;
    }
    if (found) out[j] = e;
  }
  return out;
}

// misfit_check()'s scan of windows (misfit_scan.h).
// [[Rcpp::export]]
Rcpp::List misfit_scan_cpp(const Rcpp::NumericVector& m, const Rcpp::NumericMatrix& Et) {
  return wavevalid::misfit_scan(m, Et);
}
