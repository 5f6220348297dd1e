// Data, priors, settings and output of the modular Metropolis-Hastings
// sampler (sampler.h), and its draw of the coefficients, free of R types.
#ifndef WAVEVALID_SAMPLER_MODEL_H
#define WAVEVALID_SAMPLER_MODEL_H

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>
#include "gasp_predict.h"

namespace wavevalid {

struct SiteData {
  const GaspBank* bank = nullptr;
  Eigen::VectorXd wbar, s2;      // n
  double R = 1.0;                // number of replicates
  bool fixed_sigma2 = false;
  Eigen::VectorXd sigma2_fixed;  // n, used when fixed_sigma2
  Eigen::VectorXd extra;         // n, variance of wbar beyond sigma2 / R (registration); zeros if none
  Eigen::MatrixXd shift_U;       // n x K, the field means' change per unit of each registration shift
                                 // (settings.reg_shift_var); no columns: the site has none
  Eigen::VectorXd wbar0;         // n, the field means as registered (wbar = wbar0 - shift_U a)
  std::vector<int> group;        // n, global tau2 group of each coefficient (a group may span
                                 // sites: the same level in several experiments)
  int bias_of = -1;              // >= 0: this site's bias coefficients are those of that site
                                 // (one bias shared by experiments); -1: its own
  Eigen::VectorXd shift;         // p, change of the inputs at which this site's emulators are
                                 // evaluated (an experiment's known change); empty: none
  // Noise learned in the posterior: one sigma2 for all coefficients, a random
  // walk on log sigma2, prior half-Cauchy (family 0) or half-normal (1) on
  // sigma with scale noise_scale.
  bool learn_sigma2 = false;
  double noise_scale = 1.0;
  int noise_family = 0;
  // The learned sigma2 is that of one measurement; coefficient i of the field
  // curve has noise variance noise_mult(i) * sigma2 (the resampling of the
  // measurements onto the grid; empty: 1 for all). Repeated measurements at
  // one time stamp add their scatter, noise_ss / sigma2 ~ chi^2_(noise_df).
  Eigen::VectorXd noise_mult;
  double noise_ss = 0.0, noise_df = 0.0;

  double mult(int i) const { return noise_mult.size() ? noise_mult(i) : 1.0; }

  // Log prior of eta = log sigma2 (up to a constant): the prior of sigma times
  // d sigma / d eta = sigma / 2 (with `jacobian`).
  double log_prior_eta(double eta, bool jacobian = true) const {
    const double s2 = std::exp(eta) / (noise_scale * noise_scale);
    const double lp = noise_family == 0 ? -std::log1p(s2) : -0.5 * s2;
    return jacobian ? lp + 0.5 * eta : lp;
  }
};

struct InputPrior {
  double lower = 0.0, upper = 1.0;  // support
  bool normal = false;              // manufacturing variation: truncated normal about x_nom
  // 0 uniform, 1 normal (mean, sd), 2 log-normal (log x ~ N(mean, sd^2); density on x
  // with the Jacobian 1 / x), 3 under a joint Gaussian (JointPrior; uniform here)
  int kind = 0;
  double mean = 0.0, sd = 1.0;

  // Log density up to a constant (-inf outside the support).
  double log_density(double x) const {
    if (x < lower || x > upper) return -std::numeric_limits<double>::infinity();
    if (kind == 1) {
      const double u = (x - mean) / sd;
      return -0.5 * u * u;
    }
    if (kind == 2) {
      const double lx = std::log(x);
      const double u = (lx - mean) / sd;
      return -0.5 * u * u - lx;
    }
    return 0.0;
  }

  // The support alone: 0 inside, -inf outside.
  double log_support(double x) const {
    return (x < lower || x > upper) ? -std::numeric_limits<double>::infinity() : 0.0;
  }

  // A draw. Manufacturing variation: the truncated normal by rejection
  // (uniform if that keeps failing). Normal and log-normal calibration
  // inputs: rejection from the untruncated prior (their box holds a prior
  // mass of 1e-4 or more, checked in R). Under a joint prior: the lower
  // bound, without a draw (JointPrior::draw sets it).
  template <class Rng>
  double draw(Rng& rng, std::normal_distribution<double>& norm,
              std::uniform_real_distribution<double>& unif) const {
    if (normal) {
      for (int t = 0; t < 1000; ++t) {
        const double x = mean + sd * norm(rng);
        if (x >= lower && x <= upper) return x;
      }
    } else if (kind == 1 || kind == 2) {
      for (long t = 0; t < 10000000L; ++t) {
        double x = mean + sd * norm(rng);
        if (kind == 2) x = std::exp(x);
        if (x >= lower && x <= upper) return x;
      }
      throw std::runtime_error("the prior of an input puts almost no mass in its range");
    } else if (kind == 3) {
      return lower;
    }
    return lower + (upper - lower) * unif(rng);
  }

  // The report's proposal for this coordinate from x: with probability 1/2
  // uniform on the support, else uniform on [x - half, x + half] cap support.
  template <class Rng>
  double mixture_draw(double x, double half, Rng& rng, std::uniform_real_distribution<double>& unif) const {
    if (unif(rng) < 0.5) return lower + (upper - lower) * unif(rng);
    const double lo = std::max(lower, x - half);
    const double hi = std::min(upper, x + half);
    return lo + (hi - lo) * unif(rng);
  }

  // Density of mixture_draw() at `to` from `from`.
  double mixture_density(double from, double to, double half) const {
    const double lo = std::max(lower, from - half);
    const double hi = std::min(upper, from + half);
    double d = 0.5 / (upper - lower);
    if (to >= lo && to <= hi && hi > lo) d += 0.5 / (hi - lo);
    return d;
  }
};

// A Gaussian over several inputs (positions `index`), each on its own scale
// (identity, or log where `log` is set), truncated to the inputs' supports.
struct JointPrior {
  std::vector<int> index;
  std::vector<char> log;
  Eigen::VectorXd mean;
  Eigen::MatrixXd L;  // lower Cholesky factor of the covariance

  // Log density of the inputs z (own units) up to a constant, the support
  // aside: the quadratic form on the scales, and the Jacobian 1 / x of each
  // log-scale input.
  double log_density(const Eigen::VectorXd& z) const {
    const int d = static_cast<int>(index.size());
    Eigen::VectorXd r(d);
    double jac = 0.0;
    for (int q = 0; q < d; ++q) {
      const double x = z(index[q]);
      if (log[q]) {
        if (!(x > 0.0)) return -std::numeric_limits<double>::infinity();
        const double lx = std::log(x);
        r(q) = lx - mean(q);
        jac += lx;
      } else {
        r(q) = x - mean(q);
      }
    }
    L.triangularView<Eigen::Lower>().solveInPlace(r);
    return -0.5 * r.squaredNorm() - jac;
  }

  // A draw into z by rejection from the untruncated Gaussian into the supports.
  template <class Rng>
  void draw(Eigen::VectorXd& z, const std::vector<InputPrior>& priors, Rng& rng,
            std::normal_distribution<double>& norm) const {
    const int d = static_cast<int>(index.size());
    Eigen::VectorXd e(d), y(d);
    for (long t = 0; t < 10000000L; ++t) {
      for (int q = 0; q < d; ++q) e(q) = norm(rng);
      y = mean + L * e;
      bool inside = true;
      for (int q = 0; q < d && inside; ++q) {
        if (log[q]) y(q) = std::exp(y(q));
        const InputPrior& p = priors[index[q]];
        inside = y(q) >= p.lower && y(q) <= p.upper;
      }
      if (inside) {
        for (int q = 0; q < d; ++q) z(index[q]) = y(q);
        return;
      }
    }
    throw std::runtime_error("a joint prior puts almost no mass in the inputs' ranges");
  }
};

// Log prior of the inputs z: the independent terms, then the joint Gaussians
// (debug_break 3: the supports alone).
inline double log_prior(const std::vector<InputPrior>& priors, const std::vector<JointPrior>& joints,
                        const Eigen::VectorXd& z, int debug_break) {
  double lp = 0.0;
  for (std::size_t k = 0; k < priors.size(); ++k)
    lp += debug_break == 3 ? priors[k].log_support(z(k)) : priors[k].log_density(z(k));
  if (debug_break == 3 || joints.empty() || !std::isfinite(lp)) return lp;
  for (const JointPrior& j : joints) lp += j.log_density(z);
  return lp;
}

// Where a chain stands after its last saved draw: what a continuation needs
// to go on exactly as the chain would have (the inputs, tau2, the
// registration's shifts, the learned noise and its step, the frozen random
// walk and the random number streams, as text).
struct ChainState {
  Eigen::VectorXd z, tau2, a;
  std::vector<double> eta, eta_step;
  Eigen::MatrixXd walk_chol, ind_chol;
  Eigen::VectorXd ind_mean;
  bool has_indep = false;
  double log_t_const = 0.0, log_box = 0.0;
  std::string rng;
};

struct SamplerSettings {
  int n_draws = 1000;
  int n_inner = 200;
  double step = 0.1;                // local half-width as a fraction of the range
  std::uint64_t seed = 1;
  int chain = 1;
  bool fix_tau2 = false;
  Eigen::VectorXd tau2_init;        // G; used as fixed values when fix_tau2, ignored if empty otherwise
  Eigen::VectorXd z_init;           // p
  int debug_break = 0;              // 1: drop the mixture-density or proposal ratio of global moves, 2: drop the tau2 ratio,
                                    // 3: drop the inputs' prior density (its support kept),
                                    // 4: drop the Jacobian of log sigma2 in the learned-noise step,
                                    // 5: drop the likelihood of the sites with an input shift,
                                    // 6: the learned noise's multipliers taken as 1,
                                    // 7: the inputs' likelihood weight taken as 1,
                                    // (8: the inputs' steps given the registration's shifts,)
                                    // 9: every log of a coefficient's variance taken afresh (the
                                    // reference of the kept logs: the same draws)
  int report_every = 50;
  bool adaptive = false;            // ADAPTIVE proposal (else the report's)
  int burnin = 0;                   // cycles before the first saved draw (adaptation in ADAPTIVE)
  double p_global = 0.1;            // ADAPTIVE: probability of the report's mixture step
  double p_indep = 0.0;             // ADAPTIVE: probability of an independence move instead (0: none)
  int n_search = 200;               // ADAPTIVE: prior draws scored for the start
  int threads = 1;                  // OpenMP threads of the emulator predictions
  std::vector<int> informs;         // G; 0: the group's coefficients do not inform the inputs
                                    // (a cut: its tau2 and bias follow the inputs); empty: all inform
  double temper = 1.0;              // power of the likelihood in the target (1: the method's posterior)
  Eigen::VectorXd reg_shift_var;    // K, prior variances of the registration's shifts (empty: none)
  bool resume = false;              // continue from `state` (no burn-in, no start search, z_init unused)
  ChainState state;
  double input_weight = 1.0;        // power of the likelihood in the inputs' steps alone: the magnitude
                                    // adjustment of the composite likelihood for errors that the
                                    // coefficients share (1: the coefficients independent, the method's)
};

struct SamplerOutput {
  Eigen::MatrixXd inputs;  // H x p
  Eigen::MatrixXd tau2;    // H x G
  std::vector<Eigen::MatrixXd> sigma2, wb, wM;  // per site, H x n
  double acc_tau = 0, n_tau = 0, acc_input = 0, n_input = 0;
  double acc_global = 0, n_global = 0, acc_burn = 0, n_burn = 0;
  Eigen::VectorXd z_start;   // first point of the burn-in
  double acc_noise = 0, n_noise = 0;  // learned-noise steps after the burn-in
  Eigen::MatrixXd prop_cov;  // frozen random-walk covariance (ADAPTIVE)
  Eigen::MatrixXd reg_shift; // H x K, the registration's shifts (K = 0: none)
  ChainState end;            // where the chain stands after its last draw
};

// One coefficient's bias and model output given the inputs (emulator mean m
// and variance V there), e = sigma2 / R and tau2: w^b from eq. (17), then w^M
// from eq. (16).
template <class Rng>
inline void draw_bias_and_model(double wbar, double m, double V, double e, double t2, Rng& rng,
                                std::normal_distribution<double>& norm, double& wb, double& wM) {
  const double S = V + e;
  wb = t2 / (S + t2) * (wbar - m) + std::sqrt(t2 * S / (S + t2)) * norm(rng);
  wM = S > 0.0 ? V / S * (wbar - wb) + e / S * m + std::sqrt(V * e / S) * norm(rng) : m;
}

}  // namespace wavevalid

#endif
