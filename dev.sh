#!/usr/bin/env bash
# gearfem developer/user entry point. From a fresh clone:
#
#   ./dev.sh run [CASE.toml] [gearfem run options]   set up .venv, run the main job (default: thesis case,
#                                                    results/thesis, on GEARFEM_NP ranks, default 2)
#   ./dev.sh test [pytest options]                   set up .venv, run the tests on 1 rank (2 pytest-xdist
#                                                    workers), then the mpi-marked ones (only) under mpirun -n 2
#   ./dev.sh test --quick [pytest options]           the quick tier (tests not marked slow; a few minutes)
#   ./dev.sh docs [sphinx options]                   build the documentation site into docs/_build/html
#   ./dev.sh setup                                   only set up .venv
#   ./dev.sh gearfem ARGS...                         any gearfem command inside the environment
#
# Set-up: finds a Python >= 3.12 (GEARFEM_PYTHON, python3.13/3.12/python3 on PATH, then pyenv's
# versions), creates the virtual environment GEARFEM_VENV (default .venv) and installs gearfem with
# its dependencies from pyproject.toml. Where that Python already imports DOLFINx >= 0.10 (conda,
# container), the venv sees it (--system-site-packages) and the PyPI wheel is not installed;
# otherwise DOLFINx 0.11 comes from the wheel dolfinx-solver-real (extra "fenics"). The extra "test"
# is always installed, "docs" (Sphinx) by `./dev.sh docs` and the full test tier, which builds the
# site. Re-running is cheap: the install is redone only when pyproject.toml changes or an extra is
# asked for that the venv lacks (the stamp holds pyproject.toml's hash and the extras installed).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$ROOT"
VENV="${GEARFEM_VENV:-$ROOT/.venv}"
MPI_NP="${GEARFEM_TEST_NP:-2}"

say() { printf '[dev.sh] %s\n' "$*" >&2; }
die() { printf '[dev.sh] error: %s\n' "$*" >&2; exit 1; }

py_ok() {  # $1: interpreter; true when it runs and is >= 3.12
  "$1" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 12) else 1)' >/dev/null 2>&1
}

find_python() {
  local c
  if [[ -n "${GEARFEM_PYTHON:-}" ]]; then
    py_ok "$GEARFEM_PYTHON" || die "GEARFEM_PYTHON=$GEARFEM_PYTHON is not a Python >= 3.12"
    echo "$GEARFEM_PYTHON"; return
  fi
  for c in python3.12 python3.13 python3 python; do
    if command -v "$c" >/dev/null 2>&1 && py_ok "$(command -v "$c")"; then command -v "$c"; return; fi
  done
  local roots=()
  command -v pyenv >/dev/null 2>&1 && roots+=("$(pyenv root 2>/dev/null)")
  roots+=("${PYENV_ROOT:-}" "$HOME/.pyenv")
  for r in "${roots[@]}"; do
    [[ -n "$r" && -d "$r/versions" ]] || continue
    # Prefer 3.12 (what the stack is tested on), then newer minors; newest patch first.
    for minor in 12 13 14 15; do
      for c in $(ls -d "$r"/versions/3."$minor".* 2>/dev/null | sort -t. -k3,3nr); do
        if [[ -x "$c/bin/python3" ]] && py_ok "$c/bin/python3"; then echo "$c/bin/python3"; return; fi
      done
    done
  done
  die "no Python >= 3.12 found. Install one (e.g. 'pyenv install 3.12', 'apt install python3.12 python3.12-venv', or conda), or point GEARFEM_PYTHON at it."
}

setup() {  # $@: extras wanted beyond "test" (e.g. docs)
  local stamp="$VENV/.gearfem-install-stamp" want hash="" have="" e
  want="$(cat pyproject.toml | sha256sum | cut -c1-16)"
  # the stamp: pyproject.toml's hash, then the extras installed (a stamp of the hash alone: "test")
  if [[ -x "$VENV/bin/python" && -f "$stamp" ]]; then
    read -r hash have < "$stamp" || true
    have="${have:-test}"
  fi
  local wanted="test"  # the extras to install: "test", those asked for, and those the venv has
  for e in "$@" ${have//,/ }; do [[ ",$wanted," == *",$e,"* ]] || wanted="$wanted,$e"; done
  if [[ -x "$VENV/bin/python" && "$hash" == "$want" && ",$have," == *",test,"* ]]; then
    local missing=0
    for e in "$@"; do [[ ",$have," == *",$e,"* ]] || missing=1; done
    [[ $missing -eq 1 ]] || return 0
  fi
  local py; py="$(find_python)"
  local extras="$wanted" sys_site=""
  if "$py" -c 'import dolfinx, sys; v = tuple(int(x) for x in dolfinx.__version__.split(".")[:2]); sys.exit(0 if v >= (0, 10) else 1)' >/dev/null 2>&1; then
    say "DOLFINx found in $py: using it (no PyPI wheel)"; sys_site="--system-site-packages"
  else
    extras="fenics,$wanted"
  fi
  if [[ ! -x "$VENV/bin/python" ]]; then
    say "creating $VENV with $py ($("$py" --version 2>&1))"
    "$py" -m venv $sys_site "$VENV" || die "could not create a venv with $py (on Debian/Ubuntu: apt install python3-venv)"
  fi
  say "installing gearfem[$extras] into $VENV (first time: about a minute)"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip >/dev/null
  # the installed modules' bytecode compiled afterwards on every core (compileall -j 0) instead
  # of one file after another by pip: 26 + 12 s against 46 s on 2 cores; like pip, a file that
  # does not compile is left to Python to report when it is imported
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-compile -e ".[$extras]" \
    || die "pip install of gearfem[$extras] failed (see above)"
  "$VENV/bin/python" -m compileall -qq -j 0 "$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')" >/dev/null 2>&1 || true
  "$VENV/bin/python" -c 'import gearfem' || die "gearfem does not import after installation"
  echo "$want $wanted" > "$stamp"
}

mpirun_cmd() {
  if [[ -x "$VENV/bin/mpirun" ]]; then echo "$VENV/bin/mpirun"; else command -v mpirun || die "mpirun not found"; fi
}

run_pytest() {  # run pytest; exit code 5 (nothing collected) is a failure, never a silent pass
  local rc=0
  "$@" || rc=$?
  if [[ $rc -eq 5 ]]; then die "pytest collected no tests: $*"; fi
  return $rc
}

cmd="${1:-}"; shift || true
export PYVISTA_OFF_SCREEN=true MPLBACKEND=Agg
case "$cmd" in
  setup) setup ;;
  run)
    setup
    args=("$@")
    if [[ ${#args[@]} -eq 0 || "${args[0]}" == -* ]]; then out_given=0; for a in "${args[@]}"; do [[ "$a" == "--out" ]] && out_given=1; done
      [[ $out_given -eq 1 ]] || args+=(--out results/thesis)
    fi
    np="${GEARFEM_NP:-$( (( $(nproc 2>/dev/null || echo 1) >= 2 )) && echo 2 || echo 1)}"
    say "gearfem run ${args[*]} on $np MPI rank(s) (GEARFEM_NP)"
    exec "$(mpirun_cmd)" -n "$np" "$VENV/bin/gearfem" run "${args[@]}"
    ;;
  test)
    # Each test runs in one tier: the mpi-marked ones only under mpirun, where those comparing 1
    # with N ranks compute on COMM_SELF as well (a 1-rank run of them repeated that computation).
    serial_mark=(-m "not mpi"); mpi_mark=(-m mpi); tier="full"
    if [[ "${1:-}" == "--quick" ]]; then
      shift; serial_mark=(-m "not slow and not mpi"); mpi_mark=(-m "mpi and not slow"); tier="quick"
    fi
    # the full tier builds the documentation site (tests/test_docs.py): it needs the docs extra
    if [[ "$tier" == "full" ]]; then setup docs; else setup; fi
    # Single-rank tests on GEARFEM_TEST_WORKERS pytest-xdist workers (default: the cores, at most
    # 2, the CI machine's), one BLAS thread each, distributed by file (--dist loadfile: a module's
    # fixtures are built once; loadgroup silently stopped grouping with pytest 9.2,
    # pytest-dev/pytest-xdist#1386), in collection order (--no-loadscope-reorder: the longest
    # modules first, tests/conftest.py LONGEST_MODULES); the 20 longest tests are listed at the end
    # (where a faster tier would come from). GEARFEM_TEST_WORKERS=0: in-process.
    # Bytecode is written (an environment may forbid it, PYTHONDONTWRITEBYTECODE): without it
    # every pytest process (the xdist workers, the mpirun ranks) re-rewrote the assertions of every
    # test module and recompiled gearfem at start (6.5 s against 2-3 s to collect the quick tier)
    unset PYTHONDONTWRITEBYTECODE
    workers="${GEARFEM_TEST_WORKERS:-$(( $(nproc 2>/dev/null || echo 1) >= 2 ? 2 : 1 ))}"
    [[ "$workers" =~ ^[0-9]+$ ]] || die "GEARFEM_TEST_WORKERS=$workers is not a whole number >= 0"
    t0=$SECONDS
    say "serial ($tier tier, $workers pytest-xdist workers): pytest ${serial_mark[*]} $*"
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 run_pytest "$VENV/bin/python" -m pytest \
      -n "$workers" --dist loadfile --no-loadscope-reorder --durations=20 "${serial_mark[@]}" "$@"
    say "serial tests passed in $((SECONDS - t0)) s; now the mpi-marked tests under mpirun -n $MPI_NP"
    t1=$SECONDS
    # 2.5-4 min here; a rank that failed a test can leave the others waiting in a collective
    # (its traceback is on stderr as "[rank N] FAILED"): stop after GEARFEM_MPI_TEST_TIMEOUT s.
    mpi_timeout="${GEARFEM_MPI_TEST_TIMEOUT:-1200}"
    rc=0
    run_pytest timeout "$mpi_timeout" "$(mpirun_cmd)" -n "$MPI_NP" \
      "$VENV/bin/python" -m pytest "${mpi_mark[@]}" -p no:cacheprovider --durations=15 "$@" || rc=$?
    if [[ $rc -eq 124 ]]; then
      die "the mpirun -n $MPI_NP tests did not finish in GEARFEM_MPI_TEST_TIMEOUT=$mpi_timeout s (a rank waiting for one that failed? see [rank N] FAILED above)"
    fi
    [[ $rc -eq 0 ]] || exit $rc
    say "mpirun -n $MPI_NP tests passed in $((SECONDS - t1)) s; all tests passed in $((SECONDS - t0)) s"
    ;;
  docs)
    setup docs
    say "building the documentation site into docs/_build/html (warnings are errors)"
    exec "$VENV/bin/python" -m sphinx -b html -W --keep-going -n docs docs/_build/html "$@"
    ;;
  gearfem) setup; exec "$VENV/bin/gearfem" "$@" ;;
  *) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 2 ;;
esac
