// GASP prediction for a bank of emulators that share one design (eq. 11 of
// the method): for every coefficient i at a new input z,
//   m_i(z) = mu_i + r_i(z)' a_i,            a_i = R_i^{-1} (y_i - mu_i 1)
//   V_i(z) = (1 - r_i(z)' R_i^{-1} r_i(z)) / lambda_i,
// with r_ik(z) = exp(-sum_p beta_ip |z_p - X_kp|^(2 - alpha_ip)) and
// R_i = L_i L_i' (correlation of the design, nugget on the diagonal).
// Free of R types so that the sampler and the emulator code share it.
#ifndef WAVEVALID_GASP_PREDICT_H
#define WAVEVALID_GASP_PREDICT_H

#include <Eigen/Dense>
#include <vector>
#include <cmath>
#include "vexp.h"
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef _OPENMP
#include <omp.h>
#endif

namespace wavevalid {

struct GaspBank {
  Eigen::MatrixXd X;        // K x p design, scaled to the emulators' unit cube
  Eigen::MatrixXd beta;     // n x p, >= 0
  Eigen::MatrixXd alpha;    // n x p, in [0, 1]
  Eigen::VectorXd mu;       // n
  Eigen::VectorXd lambda;   // n (precision)
  Eigen::MatrixXd weights;  // K x n, R_i^{-1}(y_i - mu_i)
  // The distinct lower Cholesky factors (K x K) and, for each coefficient,
  // the position of its own among them: coefficients that share their
  // correlation (emulators fitted per level) share one stored factor.
  std::vector<Eigen::MatrixXd> L;
  std::vector<int> lidx;           // n
  Eigen::VectorXd lower, width;    // p: z_scaled = (z - lower) / width
  Eigen::VectorXd nugget;          // n, added to the diagonal of R_i

  int n_coef() const { return static_cast<int>(mu.size()); }
  // Coefficient i's Cholesky factor.
  const Eigen::MatrixXd& chol(int i) const { return L[lidx[i]]; }
  int n_runs() const { return static_cast<int>(X.rows()); }
  int n_inputs() const { return static_cast<int>(X.cols()); }

  // Correlation vector r_i(z) for coefficient i, z already scaled.
  // d1, d2, logd: K x p matrices of |z - X|, |z - X|^2, log|z - X|; s: scratch
  // of length K; r: length K (a vector or a column of a matrix).
  void corr_vector(int i, const Eigen::MatrixXd& d1, const Eigen::MatrixXd& d2,
                   const Eigen::MatrixXd& logd, Eigen::ArrayXd& s, Eigen::Ref<Eigen::VectorXd> r) const {
    const int p = n_inputs();
    s.setZero();
    for (int q = 0; q < p; ++q) {
      const double b = beta(i, q);
      if (b == 0.0) continue;  // a zero beta makes the input irrelevant
      const double a = alpha(i, q);
      if (a == 0.0) {
        s += b * d2.col(q).array();
      } else if (a == 1.0) {
        s += b * d1.col(q).array();
      } else if (vexp_eigen_available) {
        // r as scratch: the powers |d|^(2 - a), their exps taken as Eigen
        // takes those of an expression added to s
        double* e = r.data();
        const double c = 2.0 - a;
        const double* l = logd.col(q).data();
        for (Eigen::Index k = 0; k < r.size(); ++k) e[k] = c * l[k];
        vexp_eigen(e, e, r.size(), s.data());
        s += b * r.array();
      } else {
        s += b * ((2.0 - a) * logd.col(q).array()).exp();
      }
    }
    if (vexp_eigen_available) {
      r.array() = -s;
      vexp_eigen(r.data(), r.data(), r.size());
    } else {
      r.array() = (-s).exp();
    }
  }

  void corr_vector(int i, const Eigen::MatrixXd& d1, const Eigen::MatrixXd& d2,
                   const Eigen::MatrixXd& logd, Eigen::VectorXd& r) const {
    Eigen::ArrayXd s(n_runs());
    r.resize(n_runs());
    corr_vector(i, d1, d2, logd, s, r);
  }

  // Distances of a raw input vector z to the design (no allocation when the
  // matrices already have their size).
  void distances(const Eigen::VectorXd& z, Eigen::MatrixXd& d1, Eigen::MatrixXd& d2,
                 Eigen::MatrixXd& logd) const {
    const int K = n_runs(), p = n_inputs();
    d1.resize(K, p);
    d2.resize(K, p);
    logd.resize(K, p);
    for (int q = 0; q < p; ++q) {
      const double zq = (z(q) - lower(q)) / width(q);
      d1.col(q) = (X.col(q).array() - zq).abs().matrix();
    }
    d2.array() = d1.array().square();
    logd.array() = d1.array().log();  // log(0) = -inf gives exp(-inf) = 0 as wanted
  }

  // Predictive means m and variances v (length n) at raw input z. After
  // find_shared(), coefficients that share their correlation (exactly: the
  // same beta, alpha, nugget and Cholesky factor) share one correlation
  // vector and one triangular solve, which give the same numbers as their own;
  // before it, each coefficient is its own representative.
  void predict(const Eigen::VectorXd& z, Eigen::VectorXd& m, Eigen::VectorXd& v,
               bool want_var = true) const {
    const int n = n_coef();
    const bool shared = static_cast<int>(rep.size()) == n;
    const std::size_t n_rep = shared ? uniq.size() : static_cast<std::size_t>(n);
    Eigen::MatrixXd d1, d2, logd;
    distances(z, d1, d2, logd);
    m.resize(n);
    if (want_var) v.resize(n);
    Eigen::VectorXd r;
    std::vector<Eigen::VectorXd> ru(n_rep);
    std::vector<double> qu(n_rep, 0.0);
    std::vector<char> done(n_rep, 0);
    for (int i = 0; i < n; ++i) {
      const int u = shared ? slot[i] : i, ri = shared ? rep[i] : i;
      if (!done[u]) {
        corr_vector(ri, d1, d2, logd, ru[u]);
        if (want_var) {
          r = ru[u];
          chol(ri).triangularView<Eigen::Lower>().solveInPlace(r);
          const double q = 1.0 - r.squaredNorm();
          qu[u] = q > 0.0 ? q : 0.0;
        }
        done[u] = 1;
      }
      m(i) = mu(i) + ru[u].dot(weights.col(i));
      if (want_var) v(i) = qu[u] / lambda(i);
    }
  }

  // The predictor of eq. (26): the same hyperparameters, the design augmented
  // by one raw input z with coefficient values w (length n). Each Cholesky
  // factor gains one row, [L 0; l' d] with l = L^-1 r(z), d^2 = 1 + g - l'l,
  // and the weights follow from the block inverse:
  //   a0 = [a - R^-1 r c; c],  c = (w - mu - r'a) / d^2.
  // A point that (numerically) coincides with the design has d^2 floored at
  // 1e-12 (a nugget for the new point only).
  GaspBank augment(const Eigen::VectorXd& z, const Eigen::VectorXd& w) const {
    const int K = n_runs(), p = n_inputs(), n = n_coef();
    GaspBank out;
    out.X.resize(K + 1, p);
    out.X.topRows(K) = X;
    out.X.row(K) = ((z - lower).array() / width.array()).matrix().transpose();
    out.beta = beta;
    out.alpha = alpha;
    out.mu = mu;
    out.lambda = lambda;
    out.lower = lower;
    out.width = width;
    out.nugget = nugget;
    out.weights.resize(K + 1, n);
    out.L.clear();
    out.lidx.assign(n, 0);
    Eigen::MatrixXd d1, d2, logd;
    distances(z, d1, d2, logd);
    Eigen::VectorXd r;
    for (int i = 0; i < n; ++i) {
      corr_vector(i, d1, d2, logd, r);
      const Eigen::MatrixXd& Li = chol(i);
      Eigen::VectorXd l = Li.triangularView<Eigen::Lower>().solve(r);
      double dd = 1.0 + nugget(i) - l.squaredNorm();
      if (!(dd > 1e-12)) dd = 1e-12;
      const double d = std::sqrt(dd);
      // a coefficient with its predecessor's correlation has its augmented
      // factor too (the same numbers)
      if (i > 0 && same_correlation(i, i - 1)) {
        out.lidx[i] = out.lidx[i - 1];
      } else {
        out.lidx[i] = static_cast<int>(out.L.size());
        out.L.emplace_back();
        Eigen::MatrixXd& L0 = out.L.back();
        L0.setZero(K + 1, K + 1);
        L0.topLeftCorner(K, K) = Li;
        L0.block(K, 0, 1, K) = l.transpose();
        L0(K, K) = d;
      }
      const Eigen::VectorXd a = weights.col(i);
      const double c = (w(i) - mu(i) - r.dot(a)) / dd;
      Eigen::VectorXd Rir = Li.transpose().triangularView<Eigen::Upper>().solve(l);
      out.weights.col(i).head(K) = a - c * Rir;
      out.weights(K, i) = c;
    }
    return out;
  }

  // Scratch space for predict_into(), sized once per bank.
  struct Workspace {
    Eigen::MatrixXd d1, d2, logd;
    Eigen::ArrayXd s;
    Eigen::MatrixXd r;   // K x distinct correlations: r(z) of the last mean_into(), column slot[i] for coefficient i
    Eigen::VectorXd x;   // K: forward substitution
    Eigen::VectorXd q;   // per distinct correlation: 1 - r' R^-1 r
    int threads = 1;     // OpenMP threads over coefficients (1: serial)
  };

  void init_workspace(Workspace& ws, int threads = 1) const {
    const int K = n_runs(), p = n_inputs();
    ws.threads = threads > 1 ? threads : 1;
    ws.d1.resize(K, p);
    ws.d2.resize(K, p);
    ws.logd.resize(K, p);
    ws.s.resize(K);
    ws.r.setZero(K, uniq.empty() ? n_coef() : static_cast<int>(uniq.size()));
    ws.x.resize(K);
    ws.q.resize(static_cast<Eigen::Index>(uniq.empty() ? n_coef() : uniq.size()));
  }

  // The Cholesky factors packed for the variance pass: for each distinct
  // correlation the lower triangle by columns, column j as 1 / L(j, j)
  // followed by L(j + 1 .. K - 1, j). Half the memory of the square factors,
  // read once per prediction in order.
  std::vector<double> packed;
  // Coefficients that share their correlation (the same beta, alpha, nugget
  // and Cholesky factor, as the emulators fitted per level do) share one
  // correlation vector and one triangular solve: rep[i] is the first
  // coefficient with i's correlation, uniq the list of those first ones and
  // slot[i] the position of rep[i] in uniq (and in packed). Set by pack().
  std::vector<int> rep, uniq, slot;

  std::size_t packed_stride() const {
    const std::size_t K = static_cast<std::size_t>(n_runs());
    return K * (K + 1) / 2;
  }

  bool is_packed() const {
    return static_cast<int>(rep.size()) == n_coef() &&
           packed.size() == packed_stride() * uniq.size();
  }

  void pack() {
    const int K = n_runs(), n = n_coef();
    find_shared();
    packed.resize(packed_stride() * uniq.size());
    for (std::size_t u = 0; u < uniq.size(); ++u) {
      const int i = uniq[u];
      double* P = packed.data() + packed_stride() * u;
      for (int j = 0; j < K; ++j) {
        const Eigen::MatrixXd& Li = chol(i);
        *P++ = 1.0 / Li(j, j);
        for (int k = j + 1; k < K; ++k) *P++ = Li(k, j);
      }
    }
    (void)n;
  }

  // Exact equality of everything the correlation vector and its solve use
  // (the factors are stored once per distinct value: the same position is
  // the same factor).
  void find_shared() {
    const int n = n_coef();
    rep.assign(n, 0);
    slot.assign(n, 0);
    uniq.clear();
    for (int i = 0; i < n; ++i) {
      int found = -1;
      // the coefficient just before is the usual match (a level's
      // coefficients are contiguous); otherwise scan the representatives
      if (i > 0 && same_correlation(i, rep[i - 1])) {
        found = rep[i - 1];
      } else {
        for (int u : uniq) {
          if (same_correlation(i, u)) {
            found = u;
            break;
          }
        }
      }
      if (found < 0) {
        rep[i] = i;
        slot[i] = static_cast<int>(uniq.size());
        uniq.push_back(i);
      } else {
        rep[i] = found;
        slot[i] = slot[found];
      }
    }
  }

  bool same_correlation(int i, int j) const {
    if (i == j) return true;
    if (nugget(i) != nugget(j)) return false;
    if (beta.row(i) != beta.row(j) || alpha.row(i) != alpha.row(j)) return false;
    return lidx[i] == lidx[j];
  }

  // Means m (length n) at raw input z; keeps the correlation vector of every
  // representative coefficient (uniq) in ws.r for var_into(). Inputs whose
  // beta is zero for a coefficient cost nothing for it.
  void mean_into(const Eigen::VectorXd& z, Eigen::VectorXd& m, Workspace& ws) const {
    corr_into(z, ws);
    const Workspace* w = &ws;
    for_each(n_coef(), ws.threads, ws.s, [&](int i, Eigen::ArrayXd&) { means_at(i, &w, 1, &m(i)); });
  }

  // The correlation vector of every distinct correlation at raw input z, in
  // ws.r.
  void corr_into(const Eigen::VectorXd& z, Workspace& ws) const {
    distances(z, ws.d1, ws.d2, ws.logd);
    for_each(static_cast<int>(uniq.size()), ws.threads, ws.s, [&](int u, Eigen::ArrayXd& s) {
      corr_vector(uniq[u], ws.d1, ws.d2, ws.logd, s, ws.r.col(u));
    });
  }

  // predict_into() at several inputs at once (zs[e] into m[e], v[e], with
  // workspace ws[e]), each value computed as predict_into() computes it, to
  // the bit: the weights of a coefficient and the packed factor of a
  // correlation are read from memory once for all the inputs (while they are
  // in cache) instead of once per input. The experiments of a validation
  // evaluate a site's emulators at their own inputs in every cycle.
  void predict_many(const std::vector<const Eigen::VectorXd*>& zs, const std::vector<Eigen::VectorXd*>& m,
                    const std::vector<Eigen::VectorXd*>& v, const std::vector<Workspace*>& ws) const {
    const int E = static_cast<int>(zs.size());
    for (int e = 0; e < E; ++e) corr_into(*zs[e], *ws[e]);
    for_each(n_coef(), ws[0]->threads, ws[0]->s, [&](int i, Eigen::ArrayXd&) {
      double d[4];
      for (int e0 = 0; e0 < E; e0 += 4) {
        const int ne = E - e0 < 4 ? E - e0 : 4;
        means_at(i, ws.data() + e0, ne, d);
        for (int e = 0; e < ne; ++e) (*m[e0 + e])(i) = d[e];
      }
    });
    for_each(static_cast<int>(uniq.size()), ws[0]->threads, ws[0]->x, [&](int u, Eigen::VectorXd& x) {
      for (int e = 0; e < E; ++e) ws[e]->q(u) = unexplained(u, *ws[e], x);
    });
    for (int e = 0; e < E; ++e) {
      for (int i = 0; i < n_coef(); ++i) (*v[e])(i) = ws[e]->q(slot[i]) / lambda(i);
    }
  }

  // Variances v (length n) at the z of the last mean_into(ws):
  // V_i = (1 - |L_i^-1 r_i|^2) / lambda_i, by column-oriented forward
  // substitution on the packed factors (pack() must have been called), once
  // per distinct correlation.
  void var_into(Eigen::VectorXd& v, Workspace& ws) const {
    for_each(static_cast<int>(uniq.size()), ws.threads, ws.x,
             [&](int u, Eigen::VectorXd& x) { ws.q(u) = unexplained(u, ws, x); });
    for (int i = 0; i < n_coef(); ++i) v(i) = ws.q(slot[i]) / lambda(i);
  }

 private:
  // f(j, scratch) for j = 0 .. count - 1; with several threads each has its
  // own scratch of K values (otherwise `serial` is used). Every j is
  // computed on its own, so the results do not depend on the number of
  // threads.
  template <class Scratch, class F>
  void for_each(int count, int threads, Scratch& serial, F f) const {
#ifdef _OPENMP
    if (threads > 1) {
#pragma omp parallel num_threads(threads)
      {
        Scratch local(n_runs());
#pragma omp for schedule(static)
        for (int j = 0; j < count; ++j) f(j, local);
      }
      return;
    }
#endif
    for (int j = 0; j < count; ++j) f(j, serial);
  }

  // 1 - |L^-1 r|^2 (floored at 0) for the u-th distinct correlation, r its
  // correlation vector in ws.r.
  double unexplained(int u, const Workspace& ws, Eigen::VectorXd& xv) const {
    const int K = n_runs();
    xv = ws.r.col(u);
    double* x = xv.data();
    const double* P = packed.data() + packed_stride() * static_cast<std::size_t>(u);
    double q = 0.0;
    // Four columns at a time: the rows below them are read and written once
    // for the four updates, which each row receives in the same order as
    // column by column (x_k - a_0 P_k0 - a_1 P_k1 - ..., left to right), so
    // the result is the same to the bit.
    int j = 0;
    for (; j + 4 <= K; j += 4) {
      const double* Pc[4];
      double a[4];
      for (int c = 0; c < 4; ++c) {
        // column j + c: 1 / L(j+c, j+c), then rows j + c + 1 .. K - 1
        Pc[c] = P;
        P += K - (j + c);
        a[c] = x[j + c] * Pc[c][0];
        q += a[c] * a[c];
        for (int r = j + c + 1; r < j + 4; ++r) x[r] -= a[c] * Pc[c][r - j - c];
      }
      // rows k >= j + 4: entry of column j + c at Pc[c][k - j - c]
      forward_rows(x + j + 4, K - j - 4, a, Pc[0] + 4, Pc[1] + 3, Pc[2] + 2, Pc[3] + 1);
    }
    for (; j < K; ++j) {
      const double xj = x[j] * (*P++);
      q += xj * xj;
      const int len = K - j - 1;
      if (len > 0) {
        Eigen::Map<Eigen::VectorXd>(x + j + 1, len) -= xj * Eigen::Map<const Eigen::VectorXd>(P, len);
        P += len;
      }
    }
    const double w = 1.0 - q;
    return w > 0.0 ? w : 0.0;
  }

  // out[e] = coefficient i's mean at the correlation vectors of ws[e], e < E
  // (at most 4): mu(i) + r' weights, summed as Eigen's dot sums it; with the
  // wide kernels (vexp.h) in AVX2 vectors where the processor has them, the
  // weights read once for all E.
  void means_at(int i, const Workspace* const* ws, int E, double* out) const {
#if WAVEVALID_VEXP_EIGEN
    const double* w = weights.col(i).data();
    const double* a[4];
    const double* b[4] = {w, w, w, w};
    for (int e = 0; e < E; ++e) a[e] = ws[e]->r.col(slot[i]).data();
    dots_eigen(a, b, E, n_runs(), out);
    for (int e = 0; e < E; ++e) out[e] = mu(i) + out[e];
#else
    const auto w = weights.col(i);
    for (int e = 0; e < E; ++e) out[e] = mu(i) + ws[e]->r.col(slot[i]).dot(w);
#endif
  }

  // x[k] = (((x[k] - a0 p0[k]) - a1 p1[k]) - a2 p2[k]) - a3 p3[k], k < len.
  static void forward_rows(double* x, int len, const double* a, const double* p0, const double* p1,
                           const double* p2, const double* p3) {
#if WAVEVALID_VEXP_EIGEN
    // the same operations per row in AVX-512 or AVX2 vectors where the
    // processor has them (vexp.h)
    sub_products4(x, len, a[0], a[1], a[2], a[3], p0, p1, p2, p3);
#else
    int k = 0;
#ifdef __SSE2__
    const __m128d a0 = _mm_set1_pd(a[0]), a1 = _mm_set1_pd(a[1]), a2 = _mm_set1_pd(a[2]), a3 = _mm_set1_pd(a[3]);
    for (; k + 2 <= len; k += 2) {
      __m128d v = _mm_loadu_pd(x + k);
      v = _mm_sub_pd(v, _mm_mul_pd(a0, _mm_loadu_pd(p0 + k)));
      v = _mm_sub_pd(v, _mm_mul_pd(a1, _mm_loadu_pd(p1 + k)));
      v = _mm_sub_pd(v, _mm_mul_pd(a2, _mm_loadu_pd(p2 + k)));
      v = _mm_sub_pd(v, _mm_mul_pd(a3, _mm_loadu_pd(p3 + k)));
      _mm_storeu_pd(x + k, v);
    }
#endif
    for (; k < len; ++k) {
      double v = x[k];
      v -= a[0] * p0[k];
      v -= a[1] * p1[k];
      v -= a[2] * p2[k];
      v -= a[3] * p3[k];
      x[k] = v;
    }
#endif
  }

 public:
  // As predict(), without allocation: m and v must already have length n, ws
  // must come from init_workspace() and the bank must be packed.
  void predict_into(const Eigen::VectorXd& z, Eigen::VectorXd& m, Eigen::VectorXd& v,
                    Workspace& ws, bool want_var = true) const {
    mean_into(z, m, ws);
    if (want_var) var_into(v, ws);
  }
};

}  // namespace wavevalid

#endif
