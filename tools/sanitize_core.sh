#!/usr/bin/env bash
# Run the C core's tests under AddressSanitizer and UndefinedBehaviorSanitizer, with the float checks
# (-fsanitize=float-divide-by-zero,float-cast-overflow) that UBSan leaves out by default.
#
#   tools/sanitize_core.sh [PYTHON] [pytest arguments ...]
#
# Builds skymodel/_core.c with gcc -O1 -g -fsanitize=address,undefined,float-divide-by-zero,float-cast-overflow
# -fno-sanitize-recover=all (the first finding aborts the run with a report), puts it in a throw-away copy
# of the skymodel package, and runs the sky core's tests (tests/test_sky_exact.py, test_sky_format.py with
# its mutation run, test_sky_render.py, test_sky_skylight.py by default) against that copy, with
# libasan preloaded into the Python interpreter. Exit status: pytest's (non-zero on any sanitizer finding).
# Needs gcc with libasan and libubsan (Debian/Ubuntu: gcc). Leak checking is off: CPython's own
# allocations at exit are not ours.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${1:-.venv/bin/python}
shift || true
TESTS=("$@")
if [ ${#TESTS[@]} -eq 0 ]; then
  TESTS=(tests/test_sky_exact.py tests/test_sky_format.py tests/test_sky_render.py tests/test_sky_skylight.py -q)
fi
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cp -r skymodel "$WORK/skymodel"
find "$WORK/skymodel" -name '_core*.so' -delete
INC=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
EXT=$("$PY" -c 'import sysconfig; print(sysconfig.get_config_var("EXT_SUFFIX"))')
SAN="-fsanitize=address,undefined,float-divide-by-zero,float-cast-overflow -fno-sanitize-recover=all"
gcc -O1 -g -fno-omit-frame-pointer -fPIC -shared -fopenmp -DWIDESKY_OPENMP=1 -fno-math-errno $SAN \
    -I"$INC" skymodel/_core.c -o "$WORK/skymodel/_core$EXT"
echo "built $WORK/skymodel/_core$EXT with $SAN"
# the editable install's import redirect would load the normal build: a sitecustomize (run after the .pth
# files, in this interpreter and in every subprocess through PYTHONPATH) drops it, so the copy is imported
cat > "$WORK/sitecustomize.py" <<PYEOF
import sys
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in type(f).__module__]
PYEOF
cat > "$WORK/run.py" <<PYEOF
import sys
import skymodel._core as core
assert core.__file__.startswith("$WORK"), core.__file__
print("sanitised core:", core.__file__, flush=True)
import pytest
sys.exit(pytest.main(sys.argv[1:] + ["-p", "no:cacheprovider"]))
PYEOF
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:halt_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
# subprocesses (the mutation test) inherit the preload, the redirect removal and the path via these
export LD_PRELOAD="$(gcc -print-file-name=libasan.so) $(gcc -print-file-name=libubsan.so)"
export PYTHONPATH="$WORK${PYTHONPATH:+:$PYTHONPATH}"
export WIDESKY_SANITIZED_CORE="$WORK/skymodel/_core$EXT"
"$PY" "$WORK/run.py" "${TESTS[@]}"
