// The scan of misfit_check() (R/diagnose-misfit.R): the field's misfit and
// its simulated errors averaged over windows of 1, 2, 4, ... points
// (misfit_scan_cpp() in bands.cpp).
#ifndef WAVEVALID_MISFIT_SCAN_H
#define WAVEVALID_MISFIT_SCAN_H

#include <Rcpp.h>
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <vector>

namespace wavevalid {

// For the misfit m (n points) and n_sim simulated errors Et (n_sim x n): at
// each width w = 1, 2, 4, ..., 2^floor(log2 n) the windows starting every
// max(1, w / 2) points and one ending at the last point; in each, the
// misfit's mean, the standard error (the root mean square of the simulated
// errors' means, at least DBL_EPSILON) and their ratio z. `zmax`: each
// simulated error's largest |mean| / se over every window; `observed`: the
// largest |z|. Sums in long double, as cumsum() and colMeans() take them.
inline Rcpp::List misfit_scan(const Rcpp::NumericVector& m, const Rcpp::NumericMatrix& Et) {
  const int n = m.size(), ns = Et.nrow();
  if (Et.ncol() != n) Rcpp::stop("one column of Et per point of the misfit");
  std::vector<double> Cm(n + 1, 0.0);
  {
    long double acc = 0.0L;
    for (int j = 0; j < n; ++j) {
      acc += m[j];
      Cm[j + 1] = static_cast<double>(acc);
    }
  }
  // running sums of each simulated error, point by point (ns values a point)
  std::vector<double> CE(static_cast<std::size_t>(n + 1) * ns, 0.0);
  {
    std::vector<long double> acc(ns, 0.0L);
    for (int j = 0; j < n; ++j) {
      const double* col = &Et(0, j);
      double* out = CE.data() + static_cast<std::size_t>(j + 1) * ns;
      for (int h = 0; h < ns; ++h) {
        acc[h] += col[h];
        out[h] = static_cast<double>(acc[h]);
      }
    }
  }
  Rcpp::NumericVector zmax(ns, 0.0);
  double observed = 0.0;
  std::vector<double> ew(ns);
  int n_w = 0;
  for (int w = 1; w <= n; w *= 2) ++n_w;
  Rcpp::List windows(n_w);
  int iw = 0;
  for (int w = 1; w <= n; w *= 2, ++iw) {
    std::vector<int> st;
    const int step = std::max(1, w / 2);
    for (int a = 1; a <= n - w + 1; a += step) st.push_back(a);
    if (st.back() != n - w + 1) st.push_back(n - w + 1);
    const int k = st.size();
    Rcpp::IntegerVector start(k);
    Rcpp::NumericVector mean(k), se(k), z(k);
    for (int i = 0; i < k; ++i) {
      const int a = st[i];
      start[i] = a;
      mean[i] = (Cm[a - 1 + w] - Cm[a - 1]) / w;
      const double* hi = CE.data() + static_cast<std::size_t>(a - 1 + w) * ns;
      const double* lo = CE.data() + static_cast<std::size_t>(a - 1) * ns;
      long double ss = 0.0L;
      for (int h = 0; h < ns; ++h) {
        ew[h] = (hi[h] - lo[h]) / w;
        ss += ew[h] * ew[h];
      }
      ss /= ns;
      se[i] = std::max(std::sqrt(static_cast<double>(ss)), DBL_EPSILON);
      for (int h = 0; h < ns; ++h) zmax[h] = std::max(zmax[h], std::abs(ew[h]) / se[i]);
      z[i] = mean[i] / se[i];
      observed = std::max(observed, std::abs(z[i]));
    }
    windows[iw] = (Rcpp::List::create(Rcpp::Named("width") = w, Rcpp::Named("start") = start,
                                         Rcpp::Named("mean") = mean, Rcpp::Named("se") = se,
                                         Rcpp::Named("z") = z));
    if (w > n / 2) break;
    Rcpp::checkUserInterrupt();
  }
  return Rcpp::List::create(Rcpp::Named("windows") = windows, Rcpp::Named("zmax") = zmax,
                            Rcpp::Named("observed") = observed);
}

}  // namespace wavevalid

#endif
