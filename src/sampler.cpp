// R glue for the modular Metropolis-Hastings sampler (one chain per call).
#include <RcppEigen.h>
#include <memory>
#include "sampler.h"

// [[Rcpp::depends(RcppEigen)]]

namespace wavevalid {
GaspBank bank_from_list(const Rcpp::List& b);
}

// sites: list of lists with bank, wbar, s2, R, sigma2 (NULL or length n),
//   group (0-based global tau2 group per coefficient), extra (optional,
//   length n: variance of wbar added to sigma2 / R).
// priors: list with lower, upper, normal (logical), mean, sd (length p each).
// progress: R function called with the number of finished draws, or NULL.
// [[Rcpp::export]]
Rcpp::List calibrate_chain_cpp(const Rcpp::List& sites, const Rcpp::List& priors, int n_groups,
                               const Eigen::Map<Eigen::VectorXd>& z_init,
                               const Eigen::Map<Eigen::VectorXd>& tau2_init, bool fix_tau2,
                               int n_draws, int n_inner, double step, double seed, int chain,
                               int debug_break, Rcpp::RObject progress, bool adaptive = false,
                               int burnin = 0, double p_global = 0.1, int n_search = 200,
                               int threads = 1, Rcpp::IntegerVector informs = Rcpp::IntegerVector::create(),
                               double temper = 1.0) {
  const int S = sites.size();
  std::vector<wavevalid::GaspBank> banks(S);
  std::vector<wavevalid::SiteData> data(S);
  for (int s = 0; s < S; ++s) {
    Rcpp::List si = sites[s];
    banks[s] = wavevalid::bank_from_list(si["bank"]);
    banks[s].pack();
    wavevalid::SiteData& d = data[s];
    d.wbar = Rcpp::as<Eigen::VectorXd>(si["wbar"]);
    d.s2 = Rcpp::as<Eigen::VectorXd>(si["s2"]);
    d.R = Rcpp::as<double>(si["R"]);
    Rcpp::RObject sg = si["sigma2"];
    if (!sg.isNULL()) {
      d.fixed_sigma2 = true;
      d.sigma2_fixed = Rcpp::as<Eigen::VectorXd>(sg);
    }
    Rcpp::IntegerVector grp = si["group"];
    d.group.assign(grp.begin(), grp.end());
    const int n = banks[s].n_coef();
    Rcpp::RObject ex = si.containsElementNamed("extra") ? si["extra"] : Rcpp::RObject(R_NilValue);
    d.extra = ex.isNULL() ? Eigen::VectorXd::Zero(n) : Rcpp::as<Eigen::VectorXd>(ex);
    if (d.wbar.size() != n || d.s2.size() != n || static_cast<int>(d.group.size()) != n ||
        (d.fixed_sigma2 && d.sigma2_fixed.size() != n) || d.extra.size() != n || (d.extra.array() < 0).any())
      Rcpp::stop("site %d: data do not match the emulator bank (%d coefficients)", s + 1, n);
    for (int i = 0; i < n; ++i)
      if (d.group[i] < 0 || d.group[i] >= n_groups) Rcpp::stop("group index out of range");
    if (banks[s].n_inputs() != z_init.size()) Rcpp::stop("z_init has the wrong length");
    if (!d.fixed_sigma2 && d.R < 2) Rcpp::stop("site %d: fewer than 2 replicates and no sigma2", s + 1);
  }
  for (int s = 0; s < S; ++s) data[s].bank = &banks[s];

  Rcpp::NumericVector lo = priors["lower"], hi = priors["upper"], mean = priors["mean"],
                      sd = priors["sd"];
  Rcpp::LogicalVector nrm = priors["normal"];
  std::vector<wavevalid::InputPrior> pr(lo.size());
  for (R_xlen_t k = 0; k < lo.size(); ++k) {
    pr[k].lower = lo[k];
    pr[k].upper = hi[k];
    pr[k].normal = nrm[k];
    pr[k].mean = mean[k];
    pr[k].sd = sd[k];
  }
  if (static_cast<int>(pr.size()) != z_init.size()) Rcpp::stop("priors and z_init differ in length");

  wavevalid::SamplerSettings set;
  set.n_draws = n_draws;
  set.n_inner = n_inner;
  set.step = step;
  set.seed = static_cast<std::uint64_t>(seed);
  set.chain = chain;
  set.fix_tau2 = fix_tau2;
  set.tau2_init = tau2_init;
  set.z_init = z_init;
  set.debug_break = debug_break;
  set.report_every = std::max(1, std::min(10, n_draws / 100));
  set.adaptive = adaptive;
  set.burnin = burnin;
  set.p_global = p_global;
  set.n_search = n_search;
  set.threads = threads;
  if (informs.size() > 0 && informs.size() != n_groups) Rcpp::stop("informs must have one value per group");
  set.informs.assign(informs.begin(), informs.end());
  if (!(temper > 0.0 && temper <= 1.0)) Rcpp::stop("temper must lie in (0, 1]");
  set.temper = temper;

  const bool has_progress = !progress.isNULL();
  Rcpp::Function* fn = nullptr;
  std::unique_ptr<Rcpp::Function> holder;
  if (has_progress) {
    holder.reset(new Rcpp::Function(progress));
    fn = holder.get();
  }
  auto cb = [fn](int h) {
    Rcpp::checkUserInterrupt();
    if (fn) (*fn)(h);
  };

  wavevalid::Sampler sampler(data, pr, n_groups, set);
  sampler.check_ = [] { Rcpp::checkUserInterrupt(); };
  wavevalid::SamplerOutput out = sampler.run(cb);

  Rcpp::List sigma2(S), wb(S), wM(S);
  for (int s = 0; s < S; ++s) {
    sigma2[s] = out.sigma2[s];
    wb[s] = out.wb[s];
    wM[s] = out.wM[s];
  }
  return Rcpp::List::create(
      Rcpp::Named("inputs") = out.inputs, Rcpp::Named("tau2") = out.tau2,
      Rcpp::Named("sigma2") = sigma2, Rcpp::Named("wb") = wb, Rcpp::Named("wM") = wM,
      Rcpp::Named("acc_tau") = out.n_tau > 0 ? out.acc_tau / out.n_tau : NA_REAL,
      Rcpp::Named("acc_input") = out.n_input > 0 ? out.acc_input / out.n_input : NA_REAL,
      Rcpp::Named("acc_global") = out.n_global > 0 ? out.acc_global / out.n_global : NA_REAL,
      Rcpp::Named("acc_burnin") = out.n_burn > 0 ? out.acc_burn / out.n_burn : NA_REAL,
      Rcpp::Named("z_start") = out.z_start, Rcpp::Named("proposal_cov") = out.prop_cov);
}
