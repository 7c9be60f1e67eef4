#!/usr/bin/env bash
# Run the C core's tests under AddressSanitizer and UndefinedBehaviorSanitizer, with the float checks
# (-fsanitize=float-divide-by-zero,float-cast-overflow) that UBSan leaves out by default.
#
#   tools/sanitize_core.sh [PYTHON] [pytest arguments ...]
#   tools/sanitize_core.sh PYTHON --run SCRIPT [script arguments ...]
#
# Builds skymodel/_core.c with gcc -O1 -g -fsanitize=address,undefined,float-divide-by-zero,float-cast-overflow
# -fno-sanitize-recover=all (the first finding aborts the run with a report) into a throw-away folder, makes
# every interpreter started with this environment import it as widesky.skymodel._core (a sitecustomize puts a
# finder for it first on sys.meta_path), and runs the sky core's tests (tests/test_sky_exact.py,
# test_sky_format.py with its mutation run, test_sky_render.py, test_sky_skylight.py by default) with
# libasan preloaded into the Python interpreter. Exit status: pytest's (non-zero on any sanitizer finding).
# With --run, runs SCRIPT under the same build instead of pytest (e.g. tools/fuzz_decoder.py).
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
INC=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
EXT=$("$PY" -c 'import sysconfig; print(sysconfig.get_config_var("EXT_SUFFIX"))')
SAN="-fsanitize=address,undefined,float-divide-by-zero,float-cast-overflow -fno-sanitize-recover=all"
gcc -O1 -g -fno-omit-frame-pointer -fPIC -shared -fopenmp -DWIDESKY_OPENMP=1 -fno-math-errno $SAN \
    -I"$INC" skymodel/_core.c -o "$WORK/_core$EXT"
echo "built $WORK/_core$EXT with $SAN"
# a sitecustomize (run after the .pth files, in this interpreter and in every subprocess through PYTHONPATH)
# puts a finder first on sys.meta_path that answers widesky.skymodel._core with the sanitised build, so the
# package's own "from . import _core" imports it instead of the normal build
cat > "$WORK/sitecustomize.py" <<PYEOF
import importlib.util
import sys


class _SanitisedCore:
    @staticmethod
    def find_spec(name, path=None, target=None):
        if name == "widesky.skymodel._core":
            return importlib.util.spec_from_file_location(name, "$WORK/_core$EXT")
        return None


sys.meta_path.insert(0, _SanitisedCore)
PYEOF
cat > "$WORK/run.py" <<PYEOF
import sys
import widesky.skymodel._core as core
assert core.__file__.startswith("$WORK"), core.__file__
print("sanitised core:", core.__file__, flush=True)
import pytest
sys.exit(pytest.main(sys.argv[1:] + ["-p", "no:cacheprovider"]))
PYEOF
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:halt_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
# subprocesses (the mutation test, the fuzzer's worker) inherit the preload, the finder and the path via these
export LD_PRELOAD="$(gcc -print-file-name=libasan.so) $(gcc -print-file-name=libubsan.so)"
export PYTHONPATH="$WORK${PYTHONPATH:+:$PYTHONPATH}"
export WIDESKY_SANITIZED_CORE="$WORK/_core$EXT"
if [ "${TESTS[0]}" = "--run" ]; then
  "$PY" "${TESTS[@]:1}"
else
  "$PY" "$WORK/run.py" "${TESTS[@]}"
fi
