// R glue for GASP fitting (numerics in gasp_lik.h, gasp_level.h, gasp_optim.h and gasp_fit.h).
#include <RcppEigen.h>
#include "gasp_lik.h"
#include "gasp_level.h"
#include "gasp_fit.h"

// [[Rcpp::depends(RcppEigen)]]

// GaspSettings from a named list of its fields; absent fields keep their defaults.
static wavevalid::GaspSettings gasp_settings(Rcpp::List control) {
  wavevalid::GaspSettings set;
  auto num = [&control](const char* name, double def) {
    return control.containsElementNamed(name) ? Rcpp::as<double>(control[name]) : def;
  };
  set.lb_lo = num("lb_lo", set.lb_lo);
  set.lb_hi = num("lb_hi", set.lb_hi);
  set.maxit = static_cast<int>(num("maxit", set.maxit));
  set.n_local = static_cast<int>(num("n_local", set.n_local));
  set.n_screen = static_cast<int>(num("n_screen", set.n_screen));
  set.ftol = num("ftol", set.ftol);
  set.pgtol = num("pgtol", set.pgtol);
  set.memory = static_cast<int>(num("memory", set.memory));
  set.gauss_first = static_cast<int>(num("gauss_first", set.gauss_first));
  set.precondition = static_cast<int>(num("precondition", set.precondition));
  set.iso_half = static_cast<int>(num("iso_half", set.iso_half));
  set.screen_lo = num("screen_lo", set.screen_lo);
  set.screen_hi = num("screen_hi", set.screen_hi);
  set.alpha_lo = num("alpha_lo", set.alpha_lo);
  set.alpha_hi = num("alpha_hi", set.alpha_hi);
  if (!(set.alpha_lo >= 0.0) || !(set.alpha_hi <= 1.0) || set.alpha_lo > set.alpha_hi ||
      set.lb_lo >= set.lb_hi || set.maxit < 1 || set.n_local < 1 || set.n_screen < 0 || set.memory < 1) {
    Rcpp::stop("invalid control settings");
  }
  return set;
}

// Prior of the shared-parameter fit from a named list (type: 0 none, 1 jointly robust; a; b_mult).
static wavevalid::GaspLevelPrior gasp_level_prior(Rcpp::List prior) {
  wavevalid::GaspLevelPrior pr;
  if (prior.containsElementNamed("type")) pr.type = Rcpp::as<int>(prior["type"]);
  if (prior.containsElementNamed("a")) pr.a = Rcpp::as<double>(prior["a"]);
  if (prior.containsElementNamed("b_mult")) pr.b_mult = Rcpp::as<double>(prior["b_mult"]);
  if (pr.type < 0 || pr.type > 1 || !(pr.a >= 0.0) || !(pr.b_mult > 0.0)) Rcpp::stop("invalid prior settings");
  return pr;
}

// Profile log-likelihood and its gradient in (log beta, alpha) at theta.
// [[Rcpp::export]]
Rcpp::List gasp_loglik_cpp(const Eigen::Map<Eigen::MatrixXd>& X, const Eigen::Map<Eigen::VectorXd>& y,
                           const Eigen::Map<Eigen::VectorXd>& theta, double nugget) {
  if (theta.size() != 2 * X.cols()) Rcpp::stop("theta must have 2 p values");
  if (y.size() != X.rows()) Rcpp::stop("y must have one value per design row");
  const wavevalid::GaspDist D(X);
  wavevalid::GaspLik lik(D, y);
  Eigen::VectorXd grad;
  const double ll = lik.eval(theta, nugget, &grad, 0.0);
  if (!std::isfinite(ll)) grad = Eigen::VectorXd::Constant(theta.size(), NA_REAL);
  return Rcpp::List::create(Rcpp::Named("loglik") = ll, Rcpp::Named("gradient") = grad,
                            Rcpp::Named("mu") = lik.mu(), Rcpp::Named("sigma2") = lik.sigma2());
}

// Maximum-likelihood fit of every column of Y (K x n) on the scaled design X.
// Columns are fitted in order; the fitted parameters of the last `n_warm`
// columns with the same `group` value are warm starts of the next one. With
// `warm_only`, a column with warm starts skips the space-filling screening
// points.
// `control`: named list of GaspSettings fields (lb_lo, lb_hi, maxit, n_local,
// n_screen, ftol, memory); absent fields keep their defaults.
// [[Rcpp::export]]
Rcpp::List gasp_fit_cpp(const Eigen::Map<Eigen::MatrixXd>& X, const Eigen::Map<Eigen::MatrixXd>& Y,
                        Rcpp::IntegerVector group, Rcpp::List control, int n_warm = 2, bool warm_only = false) {
  const int K = X.rows(), p = X.cols(), n = Y.cols();
  if (Y.rows() != K) Rcpp::stop("Y must have one row per design row");
  if (group.size() != n) Rcpp::stop("group must have one value per column of Y");
  const wavevalid::GaspSettings set = gasp_settings(control);
  const wavevalid::GaspDist D(X);
  const Eigen::MatrixXd pts = wavevalid::gasp_screen_points(p, set), no_pts(2 * p, 0);
  Eigen::MatrixXd beta(n, p), alpha(n, p);
  Rcpp::NumericVector nugget(n), loglik(n);
  Rcpp::IntegerVector n_eval(n), n_grad(n);
  Rcpp::LogicalVector converged(n);
  std::vector<Eigen::VectorXd> fitted(n);
  for (int i = 0; i < n; ++i) {
    Rcpp::checkUserInterrupt();
    std::vector<Eigen::VectorXd> warm;
    for (int j = i - 1; j >= 0 && static_cast<int>(warm.size()) < n_warm; --j) {
      if (group[j] == group[i] && fitted[j].size() > 0) warm.push_back(fitted[j]);
    }
    const Eigen::VectorXd y = Y.col(i);
    // the space-filling points are screened only for a coefficient without
    // warm starts (the first of its group)
    wavevalid::GaspFit f = wavevalid::gasp_fit(D, y, warm, warm.empty() || !warm_only ? pts : no_pts, set);
    if (!std::isfinite(f.loglik)) {
      Rcpp::stop("the likelihood of coefficient %d is numerically singular at every start and nugget", i + 1);
    }
    fitted[i] = f.theta;
    beta.row(i) = f.theta.head(p).array().exp().matrix().transpose();
    alpha.row(i) = f.theta.tail(p).transpose();
    nugget[i] = f.nugget;
    loglik[i] = f.loglik;
    n_eval[i] = f.n_eval;
    n_grad[i] = f.n_grad;
    converged[i] = f.converged;
  }
  return Rcpp::List::create(Rcpp::Named("beta") = beta, Rcpp::Named("alpha") = alpha,
                            Rcpp::Named("nugget") = nugget, Rcpp::Named("loglik") = loglik,
                            Rcpp::Named("n_eval") = n_eval, Rcpp::Named("n_grad") = n_grad,
                            Rcpp::Named("converged") = converged);
}

// Emulator quantities (mu, lambda, weights, Cholesky factors, log-likelihood)
// of every column of Y at given beta, alpha (n x p) and nugget (n).
// [[Rcpp::export]]
Rcpp::List gasp_finalize_cpp(const Eigen::Map<Eigen::MatrixXd>& X, const Eigen::Map<Eigen::MatrixXd>& Y,
                             const Eigen::Map<Eigen::MatrixXd>& beta, const Eigen::Map<Eigen::MatrixXd>& alpha,
                             const Eigen::Map<Eigen::VectorXd>& nugget) {
  const int K = X.rows(), n = Y.cols();
  if (Y.rows() != K || beta.rows() != n || alpha.rows() != n || nugget.size() != n ||
      beta.cols() != X.cols() || alpha.cols() != X.cols()) {
    Rcpp::stop("gasp_finalize_cpp: inconsistent dimensions");
  }
  const Eigen::MatrixXd Xc = X;
  const wavevalid::GaspPowers powers(Xc);
  Rcpp::NumericVector mu(n), lambda(n), nug(n), loglik(n);
  Rcpp::IntegerVector chol_of(n);
  Eigen::MatrixXd weights(K, n);
  // Coefficients with the same (beta, alpha, nugget) as an earlier one (a
  // level's, fitted together) share its factorisation: factored once, the
  // factor stored once (the same numbers as factoring each).
  std::vector<int> rep;                        // the first coefficient of each factor
  std::vector<wavevalid::GaspFactor> factors;  // kept while the coefficients are finished
  auto same_hyper = [&](int i, int j) {
    return nugget(i) == nugget(j) && beta.row(i) == beta.row(j) && alpha.row(i) == alpha.row(j);
  };
  int last = -1;
  for (int i = 0; i < n; ++i) {
    if (i % 16 == 0) Rcpp::checkUserInterrupt();
    int u = -1;
    if (last >= 0 && same_hyper(i, rep[last])) {
      u = last;
    } else {
      for (std::size_t v = 0; v < rep.size(); ++v) {
        if (same_hyper(i, rep[v])) {
          u = static_cast<int>(v);
          break;
        }
      }
    }
    if (u < 0) {
      u = static_cast<int>(rep.size());
      rep.push_back(i);
      factors.push_back(wavevalid::gasp_factor(Xc, beta.row(i).transpose(), alpha.row(i).transpose(), nugget(i),
                                               &powers));
    }
    last = u;
    const wavevalid::GaspFinal f = wavevalid::gasp_finish(factors[u], Y.col(i), false);
    if (!f.ok) Rcpp::stop("the correlation matrix of coefficient %d is not positive definite", i + 1);
    mu[i] = f.mu;
    lambda[i] = f.lambda;
    nug[i] = f.nugget;
    loglik[i] = f.loglik;
    weights.col(i) = f.weights;
    chol_of[i] = u + 1;
  }
  const R_xlen_t KK = static_cast<R_xlen_t>(K) * K;
  const int m = static_cast<int>(factors.size());
  Rcpp::NumericVector ch(KK * m);
  for (int u = 0; u < m; ++u) {
    const Eigen::MatrixXd L = factors[u].llt.matrixL();
    std::copy(L.data(), L.data() + KK, ch.begin() + u * KK);
  }
  ch.attr("dim") = Rcpp::IntegerVector::create(K, K, m);
  return Rcpp::List::create(Rcpp::Named("mu") = mu, Rcpp::Named("lambda") = lambda,
                            Rcpp::Named("nugget") = nug, Rcpp::Named("loglik") = loglik,
                            Rcpp::Named("weights") = weights, Rcpp::Named("chol") = ch,
                            Rcpp::Named("chol_of") = chol_of);
}

// Objective of the shared-parameter fit of the columns of Y (gasp_level.h) and
// its gradient in (log beta, alpha) at theta.
// [[Rcpp::export]]
Rcpp::List gasp_level_loglik_cpp(const Eigen::Map<Eigen::MatrixXd>& X, const Eigen::Map<Eigen::MatrixXd>& Y,
                                 const Eigen::Map<Eigen::VectorXd>& theta, double nugget, Rcpp::List prior,
                                 int restricted = 0) {
  if (theta.size() != 2 * X.cols()) Rcpp::stop("theta must have 2 p values");
  if (Y.rows() != X.rows()) Rcpp::stop("Y must have one row per design row");
  const wavevalid::GaspDist D(X);
  const Eigen::MatrixXd Yc = Y;
  wavevalid::GaspLevelLik lik(D, Yc, gasp_level_prior(prior), restricted);
  Eigen::VectorXd grad;
  const double ll = lik.eval(theta, nugget, &grad, 0.0);
  if (!std::isfinite(ll)) grad = Eigen::VectorXd::Constant(theta.size(), NA_REAL);
  return Rcpp::List::create(Rcpp::Named("loglik") = ll, Rcpp::Named("gradient") = grad,
                            Rcpp::Named("log_prior") = lik.log_prior(theta, nullptr),
                            Rcpp::Named("mu") = lik.mu(), Rcpp::Named("sigma2") = lik.sigma2());
}

// Shared-parameter fit of all columns of Y (the coefficients of one level):
// one (beta, alpha) maximising the sum of their profile log-likelihoods plus
// the log prior, with the screening and optimiser of gasp_fit_cpp. `warm`:
// a list of starting theta vectors (log beta, alpha).
// [[Rcpp::export]]
Rcpp::List gasp_level_fit_cpp(const Eigen::Map<Eigen::MatrixXd>& X, const Eigen::Map<Eigen::MatrixXd>& Y,
                              Rcpp::List control, Rcpp::List prior, int restricted,
                              Rcpp::List warm) {
  const int p = X.cols();
  if (Y.rows() != X.rows()) Rcpp::stop("Y must have one row per design row");
  if (Y.cols() < 1) Rcpp::stop("Y must have at least one column");
  const wavevalid::GaspSettings set = gasp_settings(control);
  const wavevalid::GaspDist D(X);
  const Eigen::MatrixXd Yc = Y;
  wavevalid::GaspLevelLik lik(D, Yc, gasp_level_prior(prior), restricted);
  std::vector<Eigen::VectorXd> w;
  for (R_xlen_t i = 0; i < warm.size(); ++i) w.push_back(Rcpp::as<Eigen::VectorXd>(warm[i]));
  const Eigen::MatrixXd pts = wavevalid::gasp_screen_points(p, set);
  Rcpp::checkUserInterrupt();
  wavevalid::GaspFit f = wavevalid::gasp_fit_lik(lik, w, pts, set);
  if (!std::isfinite(f.loglik)) {
    Rcpp::stop("the shared likelihood is numerically singular at every start and nugget");
  }
  return Rcpp::List::create(Rcpp::Named("beta") = f.theta.head(p).array().exp().matrix(),
                            Rcpp::Named("alpha") = f.theta.tail(p), Rcpp::Named("theta") = f.theta,
                            Rcpp::Named("nugget") = f.nugget, Rcpp::Named("objective") = f.loglik,
                            Rcpp::Named("n_eval") = f.n_eval, Rcpp::Named("n_grad") = f.n_grad,
                            Rcpp::Named("converged") = f.converged);
}

// The wide-vector kernels of the likelihood and the sampler (vexp.h) beside
// Eigen's expressions they stand for, for their tests: exp of x written at
// each offset 0..2 of an aligned array (Eigen takes the C library's exp at
// unaligned ends), and the inverse factor and R^-1's lower triangle for a
// correlation matrix on the design X (K runs), the means' dot products and
// the variances' forward substitution on them. Returns
// the number of entries that differ in any bit, by kernel, whether the
// kernels are in use on this build, and the kernel's exp of x.
// [[Rcpp::export]]
Rcpp::List vexp_identity_cpp(const Eigen::Map<Eigen::ArrayXd>& x, const Eigen::Map<Eigen::MatrixXd>& X) {
  const Eigen::Index n = x.size();
  auto differ = [](const double* a, const double* b, Eigen::Index m) {
    int d = 0;
    for (Eigen::Index i = 0; i < m; ++i) d += std::memcmp(a + i, b + i, sizeof(double)) != 0;
    return d;
  };
  int d_exp = 0;
  Eigen::ArrayXd e1(n + 2), e2(n + 2);
  for (int off = 0; off < 3; ++off) {
    const Eigen::Index m = n - off;
    if (m <= 0) break;
    Eigen::Map<Eigen::ArrayXd> a(e1.data() + off, m), b(e2.data() + off, m);
    a = x.head(m).exp();
    wavevalid::vexp_eigen(x.data(), b.data(), m);
    d_exp += differ(a.data(), b.data(), m);
  }
  // a correlation matrix and its factor
  const int K = static_cast<int>(X.rows());
  Eigen::MatrixXd R(K, K);
  for (int j = 0; j < K; ++j)
    for (int k = 0; k < K; ++k) R(j, k) = std::exp(-4.0 * (X.row(j) - X.row(k)).squaredNorm()) + (j == k ? 1e-6 : 0.0);
  Eigen::LLT<Eigen::MatrixXd> llt(R);
  const Eigen::MatrixXd& L = llt.matrixLLT();
  Eigen::MatrixXd Linv(K, K), Ri(K, K), Ri2(K, K);
  wavevalid::InverseGram::eigen(L, Linv, Ri);
  wavevalid::InverseGram kernels;
  kernels.resize(K);
  kernels.compute(L, Ri2);
  const Eigen::MatrixXd& LT = kernels.transposed();
  int d_inv = 0, d_ri = 0;
  for (int j = 0; j < K; ++j)
    for (int i = 0; i < K; ++i) d_inv += differ(&Linv(i, j), &LT(j, i), 1);
  for (int k = 0; k < K; ++k) d_ri += differ(&Ri(k, k), &Ri2(k, k), K - k);
  // the emulators' means: dots of R's columns with the inverse factor's,
  // one to five at once, against Eigen's dot
  int d_dot = 0;
  for (int D = 1; D <= 5; ++D) {
    for (int j0 = 0; j0 + D <= K; j0 += D) {
      const double* a[5];
      const double* b[5];
      double got[5];
      for (int d = 0; d < D; ++d) {
        a[d] = R.col(j0 + d).data();
        b[d] = Linv.col((j0 + d + 1) % K).data();
      }
      wavevalid::dots_eigen(a, b, D, K, got);
      for (int d = 0; d < D; ++d) {
        const double want = R.col(j0 + d).dot(Linv.col((j0 + d + 1) % K));
        d_dot += differ(&want, &got[d], 1);
      }
    }
  }
  // the variances' forward substitution: x - a0 p0 - a1 p1 - a2 p2 - a3 p3,
  // each product and difference rounded on its own, over R's columns
  int d_sub = 0;
  if (K >= 4) {
    const double c[4] = {0.3, -1.7, 2.9, 1e-3};
    Eigen::VectorXd got = Linv.col(0), want = Linv.col(0);
    for (int k = 0; k < K; ++k) {
      volatile double v = want(k);
      for (int q = 0; q < 4; ++q) {
        volatile double prod = c[q] * R(k, q);
        v = v - prod;
      }
      want(k) = v;
    }
    wavevalid::sub_products4(got.data(), K, c[0], c[1], c[2], c[3], R.col(0).data(), R.col(1).data(),
                             R.col(2).data(), R.col(3).data());
    d_sub = differ(want.data(), got.data(), K);
  }
  Rcpp::NumericVector values(n);
  wavevalid::vexp_eigen(x.data(), values.begin(), n);
  return Rcpp::List::create(Rcpp::Named("in_use") = wavevalid::vexp_eigen_available, Rcpp::Named("values") = values,
                            Rcpp::Named("exp") = d_exp,
                            Rcpp::Named("inverse") = d_inv, Rcpp::Named("gram") = d_ri,
                            Rcpp::Named("dot") = d_dot, Rcpp::Named("sub") = d_sub);
}

// diag(R^-1) of each lower Cholesky factor of `chol` (K x K x m): column u is
// colSums(forwardsolve(chol[, , u], diag(K))^2) to the bit, the forward
// substitution in the order of the reference BLAS's dtrsm and the squares
// summed in long double as colSums() sums them.
// [[Rcpp::export]]
Rcpp::NumericMatrix gasp_inverse_diag_cpp(Rcpp::NumericVector chol) {
  Rcpp::IntegerVector dim = chol.attr("dim");
  if (dim.size() != 3 || dim[0] != dim[1]) Rcpp::stop("chol must be a K x K x m array");
  const int K = dim[0], m = dim[2];
  Rcpp::NumericMatrix out(K, m);
  std::vector<double> x(K);
  for (int u = 0; u < m; ++u) {
    const double* A = chol.begin() + static_cast<R_xlen_t>(u) * K * K;
    for (int j = 0; j < K; ++j) {
      std::fill(x.begin(), x.end(), 0.0);
      x[j] = 1.0;
      for (int k = 0; k < K; ++k) {
        if (x[k] != 0.0) {
          x[k] = x[k] / A[k + static_cast<R_xlen_t>(k) * K];
          const double xk = x[k];
          const double* ak = A + static_cast<R_xlen_t>(k) * K;
          for (int i = k + 1; i < K; ++i) x[i] = x[i] - xk * ak[i];
        }
      }
      long double s = 0.0;
      for (int i = 0; i < K; ++i) s += x[i] * x[i];
      out(j, u) = static_cast<double>(s);
    }
  }
  return out;
}
