#!/usr/bin/env bash
# Reproduces the paper's tables and figures, with rodlog's own rows beside them, in one run
# (ARCHITECTURE.md section 7): every experiment at the paper's protocol, then one report.
#
#   scripts/reproduce_paper.sh [--out DIR] [--ray ADDRESS] [--shards N] [--shecar DIR]
#                              [--rodlog BIN] [--size full|smoke] [--only NAME,...]
#
# --out DIR       where everything goes (default results/paper): DIR/NAME/ per experiment
#                 (report.md, results.json, plots/, made.txt: the commit, machine, date,
#                 options and wall time that made it) and DIR/report.md, the whole report.
# --only LIST     run only these experiments (comma-separated names of the protocol below);
#                 the others' folders already in DIR are kept and reported with their own
#                 made.txt, so a long run can be made in parts (the report says when its
#                 parts come from different commits, and lists what is missing).
# --ray ADDRESS   run each experiment sharded on a Ray cluster (scripts/ray/rodlog_ray.py;
#                 the binary and DIR must be at the same paths on every worker).
# --shards N      shards per experiment on Ray (default 2 per worker CPU the head reports).
# --shecar DIR    the shecar sample (the paper's dataset 2; GPL-3.0, not in the repository).
#                 To get it: git clone --depth 1 https://github.com/STAR-Center/shecar
#                 and pass --shecar shecar/data/monocular (00.jpg..17.jpg, handposes.txt,
#                 intrinsic.txt). Default: $RODLOG_SHARED_DATA/shecar or ../shared/data/shecar.
#                 Without it the matchers and datasets experiments run without shecar and
#                 the report says so at its top.
# --rodlog BIN    the binary (default target/release/rodlog, built if missing).
# --size SIZE     full (the protocol below, default) or smoke (a trial or two of each, small
#                 images: checks the pipeline, its numbers mean nothing).
#
# The protocol (full): matchers every set (no match pictures: shecar's photos are GPL-3.0); noise 6 levels x 100; motions 100 per count;
# datasets 100 + shecar; ablation 100 per cell; tasks 100 seeded sites (Table 4); light
# 50 runs per hour on seeded sites (Table 5), and 17:00-19:30 again with the wrist light;
# wind 0-4 m/s in 0.5 m/s bins, 50 each; maintenance 50 per bump bin.
#
# The report's summary at its top lists every figure where rodlog is behind the paper or a
# peer (each experiment's "Beside the paper" table, the `comparisons` of its results.json).
set -euo pipefail
cd "$(dirname "$0")/.."

out=results/paper
ray=""
shards=""
shecar=""
rodlog=""
size=full
only=""
while [ $# -gt 0 ]; do
    case "$1" in
        --out) out=$2; shift 2 ;;
        --ray) ray=$2; shift 2 ;;
        --shards) shards=$2; shift 2 ;;
        --shecar) shecar=$2; shift 2 ;;
        --rodlog) rodlog=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        --only) only=",$2,"; shift 2 ;;
        -h|--help) sed -n '2,34p' "$0"; exit 0 ;;
        *) echo "reproduce_paper: unknown option $1 (--help lists them)" >&2; exit 2 ;;
    esac
done
case "$size" in
    full|smoke) ;;
    *) echo "reproduce_paper: --size is full or smoke, not $size" >&2; exit 2 ;;
esac

if [ -z "$rodlog" ]; then
    rodlog=target/release/rodlog
    [ -x "$rodlog" ] || cargo build --release --locked
fi
[ -x "$rodlog" ] || { echo "reproduce_paper: $rodlog is not an executable" >&2; exit 2; }

# shecar: a folder with 00.jpg..17.jpg, handposes.txt and intrinsic.txt, seen by rodlog as
# $RODLOG_SHARED_DATA/shecar.
shecar_note=""
if [ -n "$shecar" ]; then
    [ -f "$shecar/handposes.txt" ] || { echo "reproduce_paper: $shecar has no handposes.txt (see --help for the download)" >&2; exit 2; }
    data=$(mktemp -d)
    ln -s "$(cd "$shecar" && pwd)" "$data/shecar"
    export RODLOG_SHARED_DATA="$data"
elif [ -f "${RODLOG_SHARED_DATA:-}/shecar/handposes.txt" ]; then
    :
elif [ -f ../shared/data/shecar/handposes.txt ]; then
    RODLOG_SHARED_DATA="$(cd ../shared/data && pwd)"
    export RODLOG_SHARED_DATA
else
    shecar_note="**The shecar sample was not found: the matchers and datasets tables below have no shecar rows (the paper's dataset 2).** Get it with \`git clone --depth 1 https://github.com/STAR-Center/shecar\` and rerun with \`--shecar shecar/data/monocular\`."
fi

# folder[=experiment]|options at full size|options at smoke size
protocol=(
    "matchers|--no-pictures|--trials 1 --image-scale 0.25"
    "noise|--trials 100|--trials 1 --image-scale 0.25"
    "motions|--trials 100|--trials 1 --image-scale 0.25"
    "datasets|--trials 100|--trials 1 --image-scale 0.25"
    "ablation|--trials 100|--trials 1 --image-scale 0.25"
    "tasks|--trials 100 --sites seeded|--trials 1 --sites seeded --image-scale 0.5"
    "light|--trials 50 --sites seeded|--trials 1 --hours 12,18.5 --sites seeded --image-scale 0.5"
    "light-wrist=light|--trials 50 --sites seeded --hours 17,17.5,18,18.5,19,19.5 --wrist-light on|--trials 1 --hours 19 --sites seeded --wrist-light on --image-scale 0.5"
    "wind|--trials 50 --sites seeded --speeds 0,0.5,1,1.5,2,2.5,3,3.5,4|--trials 1 --speeds 1,3 --sites seeded --image-scale 0.5"
    "maintenance|--trials 50 --sites seeded|--trials 1 --sites seeded --image-scale 0.5"
)

if [ -n "$only" ]; then
    for name in ${only//,/ }; do
        known=""
        for entry in "${protocol[@]}"; do
            folder=${entry%%|*}
            [ "${folder%%=*}" = "$name" ] && known=1
        done
        [ -n "$known" ] || { echo "reproduce_paper: --only: no experiment $name in the protocol" >&2; exit 2; }
    done
fi

# Parts kept from an earlier run must be of the same size.
if [ -n "$only" ] && [ -d "$out" ]; then
    for made_file in "$out"/*/made.txt; do
        [ -f "$made_file" ] || continue
        kept_size=$(sed -n 's/^size=//p' "$made_file")
        [ "$kept_size" = "$size" ] || {
            echo "reproduce_paper: $made_file was made at --size $kept_size, not $size: use another --out, or run it again at $size" >&2
            exit 2
        }
    done
fi

commit=$(git rev-parse HEAD 2>/dev/null || echo unknown)
dirty=$(git status --porcelain 2>/dev/null | grep -qv '^??' && echo " (with uncommitted changes)" || true)
mkdir -p "$out"
for entry in "${protocol[@]}"; do
    IFS='|' read -r folder full smoke <<<"$entry"
    name=${folder%%=*}
    experiment=${folder#*=}
    case "$only" in ""|*",$name,"*) ;; *) continue ;; esac
    opts=$full
    [ "$size" = smoke ] && opts=$smoke
    dir="$out/$name"
    rm -rf "$dir"
    t0=$(date +%s)
    echo "== $name $opts" >&2
    # shellcheck disable=SC2086 # the options are words
    if [ -n "$ray" ]; then
        n=${shards:-$("${RODLOG_REF_VENV:-.venv-ref}/bin/python" -c "import ray; ray.init(address='$ray'); print(max(1, int(ray.cluster_resources().get('CPU', 1)) * 2))" 2>/dev/null | tail -1)}
        "${RODLOG_REF_VENV:-.venv-ref}/bin/python" scripts/ray/rodlog_ray.py --address "$ray" \
            --rodlog "$rodlog" experiment "$experiment" --shards "$n" --out "$dir" -- $opts >&2
    else
        "$rodlog" experiment "$experiment" $opts --out "$dir" >&2
    fi
    wall=$(( $(date +%s) - t0 ))
    {
        echo "commit=$commit$dirty"
        echo "machine=$(uname -sm), $(nproc) cores"
        echo "date=$(date -u +%Y-%m-%d)"
        echo "size=$size"
        echo "options=$opts${ray:+ (on Ray at $ray)}"
        echo "wall_s=$wall"
    } > "$dir/made.txt"
done

# The table of parts, from each folder's made.txt (kept parts included).
made() { sed -n "s/^$2=//p" "$1/made.txt" 2>/dev/null | head -1; }
rows=""
total=0
commits=""
missing=""
for entry in "${protocol[@]}"; do
    IFS='|' read -r folder _ _ <<<"$entry"
    name=${folder%%=*}
    dir="$out/$name"
    if [ ! -f "$dir/results.json" ] || [ ! -f "$dir/made.txt" ]; then
        missing="$missing $name"
        rows="$rows| $name | not run | - | - | - |"$'\n'
        continue
    fi
    wall=$(made "$dir" wall_s)
    total=$(( total + ${wall:-0} ))
    c=$(made "$dir" commit)
    case " $commits " in *" ${c%% *} "*) ;; *) commits="$commits ${c%% *}" ;; esac
    rows="$rows| [$name]($name/report.md) | \`$(made "$dir" options)\` | ${c:0:12}${c:40} | $(made "$dir" date) | $wall |"$'\n'
done
# shellcheck disable=SC2086 # a list of words
set -- $commits
{
    echo "# The paper, reproduced"
    echo
    [ -n "$shecar_note" ] && { echo "$shecar_note"; echo; }
    [ "$size" = smoke ] && { echo "**Smoke size: a trial or two per condition on small images. These numbers check the pipeline and mean nothing.**"; echo; }
    [ -n "$missing" ] && { echo "**Not run yet:$missing.** Their tables are missing below (\`--only\` runs them into this folder)."; echo; }
    if [ $# -gt 1 ]; then
        echo "**Made in parts at $# commits ($*): each experiment's commit is in the table below.**"
        echo
    fi
    at=""
    [ $# -eq 1 ] && at=", at commit \`$1\`"
    echo "Made by \`scripts/reproduce_paper.sh --size $size${ray:+ --ray $ray}\`$at"
    echo "on $(uname -sm), $(nproc) cores; wall time ${total} s, the sum of the experiments' below"
    echo "(on a Ray cluster of N one-CPU workers the experiments' runs divide by about N: they are"
    echo "independent trials; each experiment's merge is seconds)."
    echo
    echo "## Where rodlog is behind the paper or a peer"
    echo
    # Every experiment's comparisons (results.json), the behind ones listed.
    names=()
    for entry in "${protocol[@]}"; do
        IFS='|' read -r folder _ _ <<<"$entry"
        names+=("${folder%%=*}")
    done
    python3 - "$out" "${names[@]}" <<'PY'
import json, sys
out, names = sys.argv[1], sys.argv[2:]
behind, compared, missing = [], 0, []
for name in names:
    try:
        with open(f"{out}/{name}/results.json") as f:
            comparisons = json.load(f)["sections"].get("comparisons", [])
    except OSError:
        missing.append(name)
        continue
    except (ValueError, KeyError) as e:
        behind.append(f"- **{name}**: unreadable results ({e})")
        continue
    compared += len(comparisons)
    for c in comparisons:
        if c["behind"]:
            behind.append(f"- **{name}**: {c['what']}: paper {c['paper']}; rodlog {c['rodlog']}")
if behind:
    print(f"{len(behind)} of {compared} compared figures (each experiment's \"Beside the paper\" table has them all):")
    print()
    print("\n".join(behind))
else:
    print(f"None: rodlog is level with or ahead of the paper and its peers on all {compared} compared figures.")
if missing:
    print()
    print(f"**Not compared: {', '.join(missing)} (not run yet).**")
PY
    echo
    echo "| experiment | options | commit | date | wall (s) |"
    echo "|---|---|---|---|---|"
    printf '%s' "$rows"
    echo
    for entry in "${protocol[@]}"; do
        IFS='|' read -r folder _ _ <<<"$entry"
        name=${folder%%=*}
        [ -f "$out/$name/report.md" ] || continue
        echo
        # Each experiment's report, its headings one level down and its pictures re-rooted.
        sed -e 's/^#/##/' -e "s#](plots/#]($name/plots/#g" -e "s#](images/#]($name/images/#g" "$out/$name/report.md"
    done
} > "$out/report.md"
echo "$out/report.md"
