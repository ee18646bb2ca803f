#!/usr/bin/env bash
# A non-editable install (pip install .) into a fresh venv, used from another folder: the shipped data must be
# found through the package (bpmid.data), the --help examples and `bpmid run` must work.
#   .ci/check_install.sh              # dependencies from the package index
#   DEPS_SITE=/path/to/site-packages .ci/check_install.sh   # reuse installed dependencies (offline)
set -euo pipefail
SRC="$(cd "$(dirname "$0")/.." && pwd)"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
PY="${PYTHON:-python3}"
"$PY" -m venv "$WORK/venv"
if [ -n "${DEPS_SITE:-}" ]; then
  site="$("$WORK/venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
  echo "$DEPS_SITE" > "$site/zz_deps.pth"
  "$WORK/venv/bin/pip" install -q --no-deps "$SRC"
else
  "$WORK/venv/bin/pip" install -q "$SRC"
fi
# a copy of the sources must not be importable from here: run far from the checkout
mkdir "$WORK/elsewhere" && cd "$WORK/elsewhere"
export NUMBA_CACHE_DIR="$WORK/numba" OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
unset PYTHONPATH
B="$WORK/venv/bin/bpmid"
"$WORK/venv/bin/python" -c 'import bpmid, sys; assert "site-packages" in bpmid.__file__, bpmid.__file__'
"$B" --version
"$B" run --out out/paper >/dev/null                      # the shipped study, config found through the package
test -f out/paper/report.html
"$B" shipped --copy work >/dev/null && cd work           # the examples name configs/... and datasets/...
"$B" fit relax datasets/relaxation/*.csv --out relax_fit.yaml >/dev/null
"$B" fit relax datasets/reference/pyvisco/time_user_master.csv --out master_fit.yaml >/dev/null
"$B" fit motion datasets/motion/fitting_set/*.csv --init relax_fit.yaml --out VBMM.yaml >/dev/null
"$B" predict datasets/motion/variable_amplitude/amp_2p0_r2.csv --params VBMM.yaml --out pred/ >/dev/null
"$B" compare --train datasets/motion/fitting_set/*.csv --test datasets/motion/variable_amplitude/*.csv \
  datasets/motion/variable_rate/*.csv --models vbmm-fit,gpi,maxwell-slip --out out/compare >/dev/null
"$B" compare --config configs/compare_paper.yaml --out out/compare2 >/dev/null
"$B" discover datasets/discovery/case_01/train_*.csv --holdout datasets/discovery/case_01/holdout_mixed.csv \
  --out out/discover >/dev/null
"$B" simulate configs/datasets/variable_amplitude.yaml --effect thermal_softening:amount=0.1,T=300 --seed 7 \
  --out sim/ >/dev/null
"$B" control --params VBMM.yaml --reference all --controller pi,vbmm-pi,ms-pi --plant-modulus-scale 1.05 \
  --plant-tau-scale 0.9 --out control_out >/dev/null
"$B" run configs/paper.yaml --out out/paper >/dev/null
"$B" report out/paper >/dev/null
"$WORK/venv/bin/python" -c 'import bpmid; r = bpmid.load("VBMM.yaml"); print(r)'
echo "installed bpmid: run and every help example work from $WORK/elsewhere"
