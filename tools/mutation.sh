#!/usr/bin/env bash
# Mutation testing of the search, stepping and scoring cores (a developer tool, not part of CI).
#
#   pip install mutmut            # into the project's venv (3.x; not a project dependency)
#   tools/mutation.sh             # every mutant of the three modules
#   SAMPLE=150 SEED=1 tools/mutation.sh   # a seeded random sample of at most 150 mutants per module
#   MAX_CHILDREN=2 TIME_LIMIT=3600 tools/mutation.sh
#   MUTANTS="pbr_xval.stepping.x_matrix_to_quat__mutmut_57 ..." tools/mutation.sh   # re-test these
#
# mutmut rewrites the modules in a copy: HEAD is exported to a throw-away folder ($WORKDIR, default
# a new /tmp/pbr-xval-mutation.*), and mutmut works in its mutants/ subfolder, so the checkout is
# never touched. Each mutant runs only the selected tests that execute the mutated function
# (mutmut's stats pass). Results: `cd $WORKDIR && mutmut results` (surviving mutants) and
# `mutmut show NAME`; the summary line of this script gives killed / survived / total.
# Score and selection of the last recorded run: docs/ci_regression.md ("Mutation testing").
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=${WORKDIR:-$(mktemp -d /tmp/pbr-xval-mutation.XXXXXX)}
mkdir -p "$work"
git -C "$repo" archive HEAD | tar -x -C "$work"
cd "$work"

# the targeted test selection: the tests that guard each module's documented behaviour
cat > setup.cfg <<'EOF'
[mutmut]
source_paths=pbr_xval
only_mutate=
    pbr_xval/stepping.py
    pbr_xval/study/threshold_search.py
    pbr_xval/validation/metrics.py
also_copy=
    examples/
pytest_add_cli_args=
    -p
    no:cacheprovider
    -x
pytest_add_cli_args_test_selection=
    tests/test_stepping.py
    tests/engines/test_common.py
    tests/test_quaternions.py
    tests/study/test_threshold_search.py::test_housner_search_result_is_pinned
    tests/study/test_threshold_search.py::test_housner_threshold_in_at_most_15_simulations[housner-0.0005]
    tests/study/test_threshold_search.py::test_lowest_value_toppling_prints_no_minimum
    tests/study/test_threshold_search.py::test_never_toppling_says_how_close_it_came
    tests/study/test_threshold_search.py::test_units_for_every_parameter
    tests/study/test_threshold_search.py::test_bad_search_input_is_refused_before_simulating
    tests/study/test_threshold_search.py::test_uplift_bound_only_for_a_parameter_that_scales_the_pga
    tests/study/test_thresholds.py
    tests/validation/test_metrics.py
    tests/validation/test_rule_baselines.py
EOF
# the tests find ../shared/data beside the checkout; the copy has none beside it
export PBR_XVAL_SHARED_DATA=${PBR_XVAL_SHARED_DATA:-$(dirname "$repo")/shared/data}

names=()
if [[ -n "${MUTANTS:-}" ]]; then  # re-test named mutants, e.g. the survivors of an earlier run
    read -r -a names <<< "$MUTANTS"
elif [[ -n "${SAMPLE:-}" ]]; then
    # generate the mutants only (an impossible name selects none), then draw the sample
    timeout "${TIME_LIMIT:-3600}" mutmut run --max-children "${MAX_CHILDREN:-1}" "no-such-mutant" >/dev/null 2>&1 || true
    mapfile -t names < <(python - "$SAMPLE" "${SEED:-1}" <<'EOF'
import json, random, sys
from pathlib import Path
n, seed = int(sys.argv[1]), int(sys.argv[2])
for meta in sorted(Path("mutants").rglob("*.py.meta")):
    keys = sorted(json.loads(meta.read_text())["exit_code_by_key"])
    random.Random(seed).shuffle(keys)
    print("\n".join(sorted(keys[:n])))
EOF
    )
    echo "mutation: sampled ${#names[@]} mutants (at most $SAMPLE per module, seed ${SEED:-1})"
fi
timeout "${TIME_LIMIT:-3600}" mutmut run --max-children "${MAX_CHILDREN:-1}" "${names[@]}" || echo "mutation: mutmut stopped (exit $?)"
python - <<'EOF'
import json
from collections import Counter
from pathlib import Path
from mutmut.stats import status_by_exit_code  # mutmut's own reading of each mutant's exit code
total = Counter()
for meta in sorted(Path("mutants").rglob("*.py.meta")):
    codes = json.loads(meta.read_text())["exit_code_by_key"]
    ran = {k: v for k, v in codes.items() if v is not None}
    c = Counter(status_by_exit_code[v] for v in ran.values())
    total.update(c)
    print(f"mutation: {meta.relative_to('mutants').with_suffix('')}: {len(codes)} generated, {len(ran)} run: "
          + ", ".join(f"{n} {k}" for k, n in c.most_common()))
print("mutation: total: " + ", ".join(f"{n} {k}" for k, n in total.most_common()))
EOF
echo "mutation: work folder $work (survivors: cd there; mutmut results; mutmut show NAME)"
