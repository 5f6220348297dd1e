# Entry points (see README.md):
#   make demo       install every dependency and the package, run the validation demo on the test bed
#   make readme     write README.md's paragraph on the demo from the demo's results
#   make test       install every dependency, build the package (running the vignettes: an error in one fails
#                   the build) and run R CMD check with the default test tier, its files spread over two
#                   processes; the check does not run the vignettes' code a second time
#   make test-slow  install the package and run the test suite with the slow tier switched on
#                   (WAVEVALID_SLOW_TESTS=true: full-size simulation-based calibration, coverage and diagnosis
#                   over several test beds)
#   make report-check  install Debian's chromium if missing and read the validation report in it (headless):
#                   the verdict in the first 1280 x 900 screen, no JavaScript error
# The shared library is installed stripped of its debugging information (R CMD INSTALL --strip): it is 22 of its
# 23 MB, and of its local symbols (the inlined templates' names, 87 KB). Its global symbols stay: R CMD check reads
# them (nm -Pg: the routines, the calls into R and the C library), which R's default strip command would remove.

R       ?= R
RSCRIPT ?= Rscript
OUT     ?= out
PKG      = wavevalid
VERSION  = $(shell sed -n 's/^Version: //p' DESCRIPTION)
TARBALL  = $(PKG)_$(VERSION).tar.gz

export R_STRIP_SHARED_LIB = strip --strip-debug --discard-all
# The C++ files compile two at a time (R CMD INSTALL, build and check run make with these flags).
JOBS ?= 2
RMAKE = MAKEFLAGS=-j$(JOBS)

DEB_PKGS = r-cran-rcpp r-cran-rcppeigen r-cran-wavethresh r-cran-coda r-cran-ggplot2 \
           r-cran-future r-cran-future.apply r-cran-knitr r-cran-rmarkdown r-cran-roxygen2 \
           r-cran-withr r-cran-pkgbuild r-cran-cli r-cran-rlang r-cran-testthat r-cran-callr \
           r-cran-batchtools r-cran-future.batchtools pandoc qpdf pngquant
R_PKGS   = Rcpp RcppEigen wavethresh coda ggplot2 future future.apply knitr rmarkdown roxygen2 pkgbuild \
           withr cli rlang testthat DiceKriging callr batchtools future.batchtools future.callr
# The benchmarks' peers, installed by `make bench` only
BENCH_PKGS = RobustGaSP

.PHONY: deps document install demo readme test test-slow check bench report-check sanitize clean

deps:
	@if [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends $(DEB_PKGS) >/dev/null; \
	fi
	$(RSCRIPT) tools/install-deps.R $(R_PKGS)

document:
	$(RSCRIPT) -e 'Rcpp::compileAttributes(); roxygen2::roxygenise()'

install: deps
	$(RMAKE) $(R) CMD INSTALL --preclean --no-multiarch --strip .

demo: install
	$(RSCRIPT) inst/scripts/demo.R $(OUT)

# README.md's paragraph on the demo, written from the demo's own results (tools/readme-demo.R)
readme: install
	$(RSCRIPT) tools/readme-demo.R

$(TARBALL): deps
	rm -f $(PKG)_*.tar.gz
	$(RMAKE) $(R) CMD build .

test: $(TARBALL)
	$(RSCRIPT) tools/graph.R R > .graph.txt || { cat .graph.txt; echo "R/: files or modules call each other (tools/graph.R)"; exit 1; }
	$(RMAKE) NOT_CRAN=true WAVEVALID_SLOW_TESTS=false _R_CHECK_FORCE_SUGGESTS_=false $(R) CMD check --no-manual --no-vignettes --install-args=--strip $(TARBALL)
	@mkdir -p .test-counts && $(RSCRIPT) tools/test-summary.R $(PKG).Rcheck/tests/testthat.Rout .test-counts/default.txt

# The slow tier runs on the package that `make test` checked when it is newer than the sources (as in CI),
# otherwise on the sources installed into .lib; only the test files that hold slow tests.
test-slow: deps
	@if [ -f $(PKG).Rcheck/$(PKG)/DESCRIPTION ] && \
	    [ -z "$$(find R src/*.cpp src/*.h DESCRIPTION NAMESPACE -newer $(PKG).Rcheck/$(PKG)/DESCRIPTION 2>/dev/null)" ]; then \
	  lib=$(CURDIR)/$(PKG).Rcheck; \
	else \
	  mkdir -p .lib && $(RMAKE) $(R) CMD INSTALL --preclean --no-multiarch --strip -l .lib . >/dev/null && lib=$(CURDIR)/.lib; \
	fi; \
	echo "slow tier on the package installed in $$lib"; \
	mkdir -p .test-counts && R_LIBS="$$lib$${R_LIBS:+:$$R_LIBS}" $(RSCRIPT) tools/test-slow.R .test-counts/slow.txt

check: $(TARBALL)
	$(RMAKE) $(R) CMD check --as-cran --no-manual --install-args=--strip $(TARBALL)

bench: install
	$(RSCRIPT) tools/install-deps.R $(BENCH_PKGS)
	for f in bench/*.R; do echo "== $$f"; $(RSCRIPT) $$f || exit 1; done

# The validation report read in headless Chromium (bench/bench_report_browser.R): Debian's chromium is
# installed here when missing, not by deps.
report-check: install
	@if ! command -v chromium >/dev/null 2>&1 && [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends chromium >/dev/null; \
	fi
	$(RSCRIPT) bench/bench_report_browser.R $(OUT)/report-check

sanitize: deps
	mkdir -p .sanitize && printf 'CXXFLAGS=-g -O1 -fsanitize=address,undefined -fno-omit-frame-pointer\nLDFLAGS=-fsanitize=address,undefined\n' > .sanitize/Makevars
	R_MAKEVARS_USER=$(CURDIR)/.sanitize/Makevars $(R) CMD INSTALL --preclean --no-test-load -l .sanitize .
	NOT_CRAN=true LD_PRELOAD=$$(gcc -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0 R_LIBS=$(CURDIR)/.sanitize \
	  $(RSCRIPT) -e 'testthat::test_local(".", load_package = "installed", stop_on_failure = TRUE)'

clean:
	rm -rf $(PKG)_*.tar.gz $(PKG).Rcheck .test-counts .lib src/*.o src/*.so .sanitize
