// R glue for the modular Metropolis-Hastings sampler (one chain per call).
#include <RcppEigen.h>
#include <algorithm>
#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include "sampler.h"

// [[Rcpp::depends(RcppEigen)]]

namespace wavevalid {
GaspBank bank_from_list(const Rcpp::List& b);
}

namespace {

// The settings of one chain, read once from the R list `settings` of
// calibrate_chain_cpp().
struct ChainSettings {
  int n_groups = 0;
  Rcpp::RObject progress;  // R function called with the number of finished draws, or NULL
  wavevalid::SamplerSettings sampler;
};

const char* const kRequired[] = {"n_groups", "z_init", "tau2_init", "fix_tau2", "n_draws",
                                 "n_inner", "step", "seed", "chain"};
const char* const kOptional[] = {"debug_break", "progress", "adaptive", "burnin", "p_global", "p_indep",
                                 "n_search", "threads", "informs", "temper", "input_weight",
                                 "reg_shift_var", "resume"};

bool has_entry(const Rcpp::List& x, const char* name) {
  return x.containsElementNamed(name);
}

// A required entry, or an error naming it.
SEXP required_entry(const Rcpp::List& x, const char* name) {
  if (!has_entry(x, name)) Rcpp::stop("settings: entry '%s' is missing", name);
  return x[name];
}

// One number (numeric, integer or logical, length 1, not NA).
SEXP scalar(SEXP v, const char* name) {
  const int type = TYPEOF(v);
  if ((type != REALSXP && type != INTSXP && type != LGLSXP) || Rf_xlength(v) != 1)
    Rcpp::stop("settings: entry '%s' must be a single number", name);
  if ((type == REALSXP && ISNAN(REAL(v)[0])) || (type == INTSXP && INTEGER(v)[0] == NA_INTEGER) ||
      (type == LGLSXP && LOGICAL(v)[0] == NA_LOGICAL))
    Rcpp::stop("settings: entry '%s' is NA", name);
  return v;
}

template <typename T>
T required_scalar(const Rcpp::List& x, const char* name) {
  return Rcpp::as<T>(scalar(required_entry(x, name), name));
}

template <typename T>
T optional_scalar(const Rcpp::List& x, const char* name, T value) {
  return has_entry(x, name) ? Rcpp::as<T>(scalar(x[name], name)) : value;
}

// A numeric vector (numeric or integer).
Eigen::VectorXd required_vector(const Rcpp::List& x, const char* name) {
  SEXP v = required_entry(x, name);
  if (TYPEOF(v) != REALSXP && TYPEOF(v) != INTSXP)
    Rcpp::stop("settings: entry '%s' must be a numeric vector", name);
  return Rcpp::as<Eigen::VectorXd>(v);
}

// A chain's state as a list, which settings$resume takes back.
Rcpp::List state_list(const wavevalid::ChainState& c) {
  return Rcpp::List::create(
      Rcpp::Named("z") = c.z, Rcpp::Named("tau2") = c.tau2, Rcpp::Named("a") = c.a,
      Rcpp::Named("eta") = Rcpp::wrap(c.eta), Rcpp::Named("eta_step") = Rcpp::wrap(c.eta_step),
      Rcpp::Named("walk_chol") = c.walk_chol, Rcpp::Named("ind_chol") = c.ind_chol,
      Rcpp::Named("ind_mean") = c.ind_mean, Rcpp::Named("has_indep") = c.has_indep,
      Rcpp::Named("log_t_const") = c.log_t_const, Rcpp::Named("log_box") = c.log_box,
      Rcpp::Named("rng") = c.rng);
}

// A chain's state from its list (state_list()).
wavevalid::ChainState read_state(const Rcpp::List& st) {
  wavevalid::ChainState c;
  c.z = required_vector(st, "z");
  c.tau2 = required_vector(st, "tau2");
  c.a = required_vector(st, "a");
  const Eigen::VectorXd eta = required_vector(st, "eta"), eta_step = required_vector(st, "eta_step");
  c.eta.assign(eta.data(), eta.data() + eta.size());
  c.eta_step.assign(eta_step.data(), eta_step.data() + eta_step.size());
  c.walk_chol = Rcpp::as<Eigen::MatrixXd>(required_entry(st, "walk_chol"));
  c.ind_chol = Rcpp::as<Eigen::MatrixXd>(required_entry(st, "ind_chol"));
  c.ind_mean = required_vector(st, "ind_mean");
  c.has_indep = required_scalar<bool>(st, "has_indep");
  c.log_t_const = required_scalar<double>(st, "log_t_const");
  c.log_box = required_scalar<double>(st, "log_box");
  c.rng = Rcpp::as<std::string>(required_entry(st, "rng"));
  return c;
}

ChainSettings read_settings(const Rcpp::List& x) {
  SEXP nm = Rf_getAttrib(x, R_NamesSymbol);
  if (x.size() > 0 && Rf_isNull(nm)) Rcpp::stop("settings must be a named list");
  if (!Rf_isNull(nm)) {
    Rcpp::CharacterVector names(nm);
    for (R_xlen_t i = 0; i < names.size(); ++i) {
      const std::string n = Rcpp::as<std::string>(names[i]);
      bool known = false;
      for (const char* k : kRequired) known = known || n == k;
      for (const char* k : kOptional) known = known || n == k;
      if (!known) Rcpp::stop("settings: unknown entry '%s'", n.c_str());
    }
  }
  ChainSettings out;
  wavevalid::SamplerSettings& set = out.sampler;
  out.n_groups = required_scalar<int>(x, "n_groups");
  set.z_init = required_vector(x, "z_init");
  set.tau2_init = required_vector(x, "tau2_init");
  set.fix_tau2 = required_scalar<bool>(x, "fix_tau2");
  set.n_draws = required_scalar<int>(x, "n_draws");
  set.n_inner = required_scalar<int>(x, "n_inner");
  set.step = required_scalar<double>(x, "step");
  set.seed = static_cast<std::uint64_t>(required_scalar<double>(x, "seed"));
  set.chain = required_scalar<int>(x, "chain");
  set.debug_break = optional_scalar<int>(x, "debug_break", 0);
  set.report_every = std::max(1, std::min(10, set.n_draws / 100));
  set.adaptive = optional_scalar<bool>(x, "adaptive", false);
  set.burnin = optional_scalar<int>(x, "burnin", 0);
  set.p_global = optional_scalar<double>(x, "p_global", 0.1);
  set.p_indep = optional_scalar<double>(x, "p_indep", 0.0);
  set.n_search = optional_scalar<int>(x, "n_search", 200);
  set.threads = optional_scalar<int>(x, "threads", 1);
  if (has_entry(x, "informs")) {
    SEXP v = x["informs"];
    if (TYPEOF(v) != INTSXP && TYPEOF(v) != REALSXP && !Rf_isNull(v))
      Rcpp::stop("settings: entry 'informs' must be an integer vector");
    if (!Rf_isNull(v)) {
      Rcpp::IntegerVector informs(v);
      set.informs.assign(informs.begin(), informs.end());
    }
  }
  if (!set.informs.empty() && static_cast<int>(set.informs.size()) != out.n_groups)
    Rcpp::stop("informs must have one value per group");
  set.temper = optional_scalar<double>(x, "temper", 1.0);
  if (!(set.temper > 0.0 && set.temper <= 1.0)) Rcpp::stop("temper must lie in (0, 1]");
  set.input_weight = optional_scalar<double>(x, "input_weight", 1.0);
  if (!(set.input_weight > 0.0 && set.input_weight <= 1.0)) Rcpp::stop("input_weight must lie in (0, 1]");
  if (set.debug_break == 7) set.input_weight = 1.0;
  if (has_entry(x, "reg_shift_var") && !Rf_isNull(x["reg_shift_var"]))
    set.reg_shift_var = Rcpp::as<Eigen::VectorXd>(x["reg_shift_var"]);
  if (has_entry(x, "resume") && !Rf_isNull(x["resume"])) {
    set.state = read_state(x["resume"]);
    set.resume = true;
  }
  if (has_entry(x, "progress")) {
    SEXP progress = x["progress"];
    out.progress = progress;
  }
  if (!out.progress.isNULL() && !Rf_isFunction(out.progress))
    Rcpp::stop("settings: entry 'progress' must be a function or NULL");
  return out;
}

// The inputs' priors from the R list `priors` (see calibrate_chain_cpp()).
void read_priors(const Rcpp::List& priors, std::vector<wavevalid::InputPrior>& pr,
                 std::vector<wavevalid::JointPrior>& joints) {
  Rcpp::NumericVector lo = priors["lower"], hi = priors["upper"], mean = priors["mean"],
                      sd = priors["sd"];
  Rcpp::LogicalVector nrm = priors["normal"];
  const bool has_kind = priors.containsElementNamed("kind");
  Rcpp::IntegerVector kind;
  if (has_kind) kind = Rcpp::as<Rcpp::IntegerVector>(priors["kind"]);
  if (has_kind && kind.size() != lo.size()) Rcpp::stop("priors: 'kind' has the wrong length");
  pr.assign(lo.size(), wavevalid::InputPrior());
  for (R_xlen_t k = 0; k < lo.size(); ++k) {
    pr[k].lower = lo[k];
    pr[k].upper = hi[k];
    pr[k].normal = nrm[k];
    pr[k].kind = has_kind ? kind[k] : (nrm[k] ? 1 : 0);
    if (pr[k].kind < 0 || pr[k].kind > 3) Rcpp::stop("priors: unknown kind %d", pr[k].kind);
    pr[k].mean = mean[k];
    pr[k].sd = sd[k];
  }
  if (priors.containsElementNamed("joint")) {
    Rcpp::List jl = priors["joint"];
    for (R_xlen_t j = 0; j < jl.size(); ++j) {
      Rcpp::List b = jl[j];
      wavevalid::JointPrior jp;
      Rcpp::IntegerVector idx = Rcpp::as<Rcpp::IntegerVector>(b["index"]);
      Rcpp::LogicalVector lg = Rcpp::as<Rcpp::LogicalVector>(b["log"]);
      jp.index.assign(idx.begin(), idx.end());
      jp.log.assign(lg.begin(), lg.end());
      jp.mean = Rcpp::as<Eigen::VectorXd>(b["mean"]);
      jp.L = Rcpp::as<Eigen::MatrixXd>(b["chol"]);
      const int d = static_cast<int>(jp.index.size());
      if (static_cast<int>(jp.log.size()) != d || jp.mean.size() != d || jp.L.rows() != d || jp.L.cols() != d)
        Rcpp::stop("priors: joint block %d has inconsistent sizes", static_cast<int>(j) + 1);
      for (int q = 0; q < d; ++q)
        if (jp.index[q] < 0 || jp.index[q] >= static_cast<int>(pr.size()))
          Rcpp::stop("priors: joint block %d names an input out of range", static_cast<int>(j) + 1);
      joints.push_back(jp);
    }
  }

}

// The emulator banks (one copy of a bank that several sites evaluate), the
// sites' data and the priors, read from calibrate_chain_cpp()'s arguments.
// The sites' data point into `banks`: a Problem is not copied or moved.
struct Problem {
  std::vector<wavevalid::GaspBank> banks;
  std::vector<wavevalid::SiteData> data;
  std::vector<wavevalid::InputPrior> priors;
  std::vector<wavevalid::JointPrior> joints;
};

void read_problem(const Rcpp::List& sites, const Rcpp::List& priors, const wavevalid::SamplerSettings& set,
                  int n_groups, Problem& P) {
  const Eigen::VectorXd& z_init = set.z_init;
  const int S = sites.size();
  std::vector<wavevalid::GaspBank>& banks = P.banks;
  std::vector<wavevalid::SiteData>& data = P.data;
  banks.resize(S);
  data.resize(S);
  // a site with `bank_of` evaluates an earlier site's emulators (one copy)
  std::vector<int> bank_at(S);
  for (int s = 0; s < S; ++s) {
    Rcpp::List si = sites[s];
    bank_at[s] = s;
    if (si.containsElementNamed("bank_of") && !Rf_isNull(si["bank_of"])) {
      const int o = Rcpp::as<int>(si["bank_of"]);
      if (o < 0 || o >= s || bank_at[o] != o) Rcpp::stop("site %d: bank_of must name an earlier site with its own bank", s + 1);
      bank_at[s] = o;
    } else {
      banks[s] = wavevalid::bank_from_list(si["bank"]);
      banks[s].pack();
    }
    wavevalid::SiteData& d = data[s];
    d.wbar = Rcpp::as<Eigen::VectorXd>(si["wbar"]);
    d.s2 = Rcpp::as<Eigen::VectorXd>(si["s2"]);
    d.R = Rcpp::as<double>(si["R"]);
    Rcpp::RObject sg = si["sigma2"];
    if (!sg.isNULL()) {
      d.fixed_sigma2 = true;
      d.sigma2_fixed = Rcpp::as<Eigen::VectorXd>(sg);
    }
    if (si.containsElementNamed("noise") && !Rf_isNull(si["noise"])) {
      Rcpp::List nz = si["noise"];
      d.learn_sigma2 = true;
      d.noise_scale = Rcpp::as<double>(nz["scale"]);
      d.noise_family = Rcpp::as<int>(nz["family"]);
      if (d.fixed_sigma2) Rcpp::stop("site %d: sigma2 both given and learned", s + 1);
      if (!(d.noise_scale > 0.0) || d.noise_family < 0 || d.noise_family > 1)
        Rcpp::stop("site %d: bad noise prior", s + 1);
      if (nz.containsElementNamed("mult") && !Rf_isNull(nz["mult"]))
        d.noise_mult = Rcpp::as<Eigen::VectorXd>(nz["mult"]);
      if (nz.containsElementNamed("df") && !Rf_isNull(nz["df"])) {
        d.noise_df = Rcpp::as<double>(nz["df"]);
        d.noise_ss = Rcpp::as<double>(nz["ss"]);
        if (!(d.noise_df >= 0.0) || !(d.noise_ss >= 0.0)) Rcpp::stop("site %d: bad noise evidence", s + 1);
      }
    }
    if (si.containsElementNamed("bias_of") && !Rf_isNull(si["bias_of"]))
      d.bias_of = Rcpp::as<int>(si["bias_of"]);
    if (si.containsElementNamed("shift") && !Rf_isNull(si["shift"]))
      d.shift = Rcpp::as<Eigen::VectorXd>(si["shift"]);
    if (si.containsElementNamed("reg_U") && !Rf_isNull(si["reg_U"]))
      d.shift_U = Rcpp::as<Eigen::MatrixXd>(si["reg_U"]);
    Rcpp::IntegerVector grp = si["group"];
    d.group.assign(grp.begin(), grp.end());
    const int n = banks[bank_at[s]].n_coef();
    Rcpp::RObject ex = si.containsElementNamed("extra") ? si["extra"] : Rcpp::RObject(R_NilValue);
    d.extra = ex.isNULL() ? Eigen::VectorXd::Zero(n) : Rcpp::as<Eigen::VectorXd>(ex);
    if (d.wbar.size() != n || d.s2.size() != n || static_cast<int>(d.group.size()) != n ||
        (d.fixed_sigma2 && d.sigma2_fixed.size() != n) || d.extra.size() != n || (d.extra.array() < 0).any() ||
        (d.noise_mult.size() && (d.noise_mult.size() != n || !(d.noise_mult.array() > 0).all())))
      Rcpp::stop("site %d: data do not match the emulator bank (%d coefficients)", s + 1, n);
    for (int i = 0; i < n; ++i)
      if (d.group[i] < 0 || d.group[i] >= n_groups) Rcpp::stop("group index out of range");
    if (banks[bank_at[s]].n_inputs() != z_init.size()) Rcpp::stop("z_init has the wrong length");
    if (d.shift.size() != 0 && d.shift.size() != z_init.size()) Rcpp::stop("site %d: shift has the wrong length", s + 1);
    if (!d.fixed_sigma2 && !d.learn_sigma2 && d.R < 2)
      Rcpp::stop("site %d: fewer than 2 replicates and no sigma2", s + 1);
  }
  for (int s = 0; s < S; ++s) {
    data[s].bank = &banks[bank_at[s]];
    if (set.debug_break == 6) data[s].noise_mult.resize(0);
  }

  read_priors(priors, P.priors, P.joints);
  if (static_cast<int>(P.priors.size()) != z_init.size()) Rcpp::stop("priors and z_init differ in length");

}

// A chain's run as the list calibrate_chain_cpp() returns.
Rcpp::List output_list(const wavevalid::SamplerOutput& out) {
  const int S = static_cast<int>(out.sigma2.size());
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
      Rcpp::Named("acc_noise") = out.n_noise > 0 ? out.acc_noise / out.n_noise : NA_REAL,
      Rcpp::Named("z_start") = out.z_start, Rcpp::Named("proposal_cov") = out.prop_cov,
      Rcpp::Named("reg_shift") = out.reg_shift, Rcpp::Named("state") = state_list(out.end));
}

// The R function `progress` of a chain's settings as the sampler's callback,
// which also lets the user interrupt (the main thread only).
std::function<void(int)> progress_callback(const Rcpp::RObject& progress, std::unique_ptr<Rcpp::Function>& holder) {
  Rcpp::Function* fn = nullptr;
  if (!progress.isNULL()) {
    holder.reset(new Rcpp::Function(progress));
    fn = holder.get();
  }
  return [fn](int h) {
    Rcpp::checkUserInterrupt();
    if (fn) (*fn)(h);
  };
}

}  // namespace

// sites: list of lists with bank, wbar, s2, R, sigma2 (NULL or length n),
//   noise (optional: list(scale, family) when sigma2 is learned: family 0
//   half-Cauchy, 1 half-normal on its sd; optional mult (length n: the
//   coefficients' noise variances as multiples of sigma2), ss and df (the
//   scatter of repeated measurements: ss / sigma2 ~ chi^2_df)),
//   group (0-based global tau2 group per coefficient; a group may span
//   sites), bias_of (optional, 0-based: the site whose bias coefficients this
//   site shares; its groups must be that site's), shift (optional, length p:
//   the change of the inputs at which the
//   site's emulators are evaluated), extra (optional, length n: variance of
//   wbar added to sigma2 / R).
// priors: list with lower, upper, normal (logical: manufacturing variation),
//   mean, sd (length p each); optional kind (0 uniform, 1 normal, 2 log-normal
//   with mean and sd of log x, 3 under a joint block; default from normal) and
//   joint (list of blocks: index (0-based), log (logical), mean, chol (lower
//   Cholesky factor of the covariance)).
// settings: named list with
//   n_groups (number of tau2 groups), z_init (p starting inputs, coded),
//   tau2_init (G values, fixed when fix_tau2; may be empty otherwise),
//   fix_tau2, n_draws, n_inner, step, seed, chain;
//   optional: debug_break (0; 1: no proposal-density ratio of the global moves, 2: no tau2 ratio,
//   3: no prior density of the inputs, 4: no Jacobian in the learned-noise step,
//   5: no likelihood of the sites with a shift, 6: the learned noise's multipliers taken as 1,
//   8: the inputs' steps given the registration's shifts, not with them integrated out; only to show that the
//   simulation-based checks detect errors), progress
//   (R function called with the number of finished draws, or NULL), adaptive
//   (FALSE), burnin (0), p_global (0.1), p_indep (0), n_search (200), threads (1), informs
//   (one 0/1 per group, or empty: all inform), temper (1), input_weight (1: the power of the
//   likelihood in the inputs' steps alone; debug_break 7 takes it as 1).
// [[Rcpp::export]]
Rcpp::List calibrate_chain_cpp(const Rcpp::List& sites, const Rcpp::List& priors,
                               const Rcpp::List& settings) {
  const ChainSettings cs = read_settings(settings);
  const wavevalid::SamplerSettings& set = cs.sampler;
  const int n_groups = cs.n_groups;
  Problem P;
  read_problem(sites, priors, set, n_groups, P);
  std::unique_ptr<Rcpp::Function> holder;
  const std::function<void(int)> cb = progress_callback(cs.progress, holder);
  wavevalid::Sampler sampler(P.data, P.priors, n_groups, set, P.joints);
  sampler.check_ = [] { Rcpp::checkUserInterrupt(); };
  return output_list(sampler.run(cb));
}

// The chains of `settings` (a list of calibrate_chain_cpp()'s settings, one
// per chain, differing only in chain, resume and progress) run together, each
// on a thread of its own, their predictions made in step (sampler_team.h):
// the list of their runs, each what calibrate_chain_cpp() returns for it.
// Only the first chain's progress is reported (on the main thread, which
// runs it and lets the user interrupt); its threads setting is ignored.
// [[Rcpp::export]]
Rcpp::List calibrate_team_cpp(const Rcpp::List& sites, const Rcpp::List& priors, const Rcpp::List& settings) {
  const int C = settings.size();
  if (C < 1) Rcpp::stop("settings: no chain");
  std::vector<ChainSettings> cs;
  for (int c = 0; c < C; ++c) cs.push_back(read_settings(settings[c]));
  for (int c = 1; c < C; ++c) {
    if (cs[c].n_groups != cs[0].n_groups || cs[c].sampler.z_init.size() != cs[0].sampler.z_init.size() ||
        cs[c].sampler.debug_break != cs[0].sampler.debug_break)
      Rcpp::stop("settings: the chains of a team must share their problem");
  }
  const int n_groups = cs[0].n_groups;
  Problem P;
  read_problem(sites, priors, cs[0].sampler, n_groups, P);
  std::vector<std::unique_ptr<wavevalid::Sampler>> chains;
  for (int c = 0; c < C; ++c) {
    wavevalid::SamplerSettings set = cs[c].sampler;
    set.threads = 1;
    chains.emplace_back(new wavevalid::Sampler(P.data, P.priors, n_groups, set, P.joints));
  }
  wavevalid::PredictTeam team(C, chains[0]->n_bank_groups(),
                              [&chains](int c, int g, wavevalid::BankCall& call) { chains[c]->team_group(g, call); });
  for (int c = 0; c < C; ++c) chains[c]->join_team(&team, c);
  std::vector<wavevalid::SamplerOutput> outs(C);
  std::vector<std::exception_ptr> errs(C);
  auto body = [&](int c, std::function<void(int)> cb) {
    try {
      outs[c] = chains[c]->run(cb);
    } catch (...) {
      errs[c] = std::current_exception();
      team.stop();
    }
    team.leave();
  };
  std::vector<std::thread> threads;
  for (int c = 1; c < C; ++c) {
    try {
      threads.emplace_back(body, c, [](int) {});
    } catch (...) {
      team.stop();
      for (std::thread& t : threads) t.join();
      Rcpp::stop("could not start a thread for each chain");
    }
  }
  std::unique_ptr<Rcpp::Function> holder;
  chains[0]->check_ = [] { Rcpp::checkUserInterrupt(); };
  body(0, progress_callback(cs[0].progress, holder));
  for (std::thread& t : threads) t.join();
  // the error that stopped the team, not those it caused
  for (int c = 0; c < C; ++c) {
    if (!errs[c]) continue;
    try {
      std::rethrow_exception(errs[c]);
    } catch (const wavevalid::TeamStopped&) {
      continue;
    }
  }
  Rcpp::List out(C);
  for (int c = 0; c < C; ++c) out[c] = output_list(outs[c]);
  return out;
}

// A chain's state (state_list()) with its frozen walk learned anew from its
// draws Z (one row per draw, at least 20 per input) by the walk's own rule
// (AdaptiveWalk::learn_from_draws()); NULL when their covariance is not
// positive definite. priors as for calibrate_chain_cpp().
// [[Rcpp::export]]
SEXP relearn_walk_cpp(const Rcpp::List& priors, const Rcpp::List& state, const Eigen::Map<Eigen::MatrixXd>& Z) {
  std::vector<wavevalid::InputPrior> pr;
  std::vector<wavevalid::JointPrior> joints;
  read_priors(priors, pr, joints);
  wavevalid::ChainState st = read_state(state);
  wavevalid::AdaptiveWalk walk;
  walk.init(pr);
  try {
    walk.restore(st);
    if (!walk.learn_from_draws(Z)) return R_NilValue;
  } catch (const std::invalid_argument& e) {
    Rcpp::stop(e.what());
  }
  walk.save(st);
  return state_list(st);
}

// Log prior density of the inputs at each row of Z (own units), as the
// sampler evaluates it, up to a constant; priors as for calibrate_chain_cpp().
// [[Rcpp::export]]
Rcpp::NumericVector input_log_prior_cpp(const Rcpp::List& priors, const Eigen::Map<Eigen::MatrixXd>& Z,
                                        int debug_break = 0) {
  std::vector<wavevalid::InputPrior> pr;
  std::vector<wavevalid::JointPrior> joints;
  read_priors(priors, pr, joints);
  if (Z.cols() != static_cast<Eigen::Index>(pr.size())) Rcpp::stop("Z must have one column per input");
  Rcpp::NumericVector out(Z.rows());
  for (Eigen::Index r = 0; r < Z.rows(); ++r) {
    const Eigen::VectorXd z = Z.row(r).transpose();
    out[r] = wavevalid::log_prior(pr, joints, z, debug_break);
  }
  return out;
}
