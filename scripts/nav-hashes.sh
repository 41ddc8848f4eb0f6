#!/usr/bin/env bash
# Hashes of `hal-sim nav`'s outputs on the real drive in seven settings, for checking that a
# change meant to be exact leaves every output alone: run it with the binary built before and
# after the change, then diff the two HASHES files (BENCHMARKS.md "CI time: bit-exact kernels").
#
#   bash scripts/nav-hashes.sh BIN OUT      # writes OUT/hashes.txt; BIN a built hal-sim
#
# Settings: the bank (`--adapt --adapt-method bank`) in f64 and f32; the offline
# `--identify --diagnose`; the window search (`--adapt`); the bank deciding every 60 s in f64,
# f32 and with the non-holonomic constraint. The run time (lines with "seconds", and the
# report's "run time" row) and OUT's own path are left out of the hashes.
set -euo pipefail
if [ $# -ne 2 ]; then
    echo "usage: bash scripts/nav-hashes.sh HAL_SIM_BINARY OUT" >&2
    exit 64
fi
bin=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
out=$2
data="${DATA:-$(cd "$(dirname "$0")/.." && pwd)/../shared/data/real/rtklib-drive-0708}"
for f in imu_1934.csv imu_1934.csv.tag gnss_1934_sf.pos; do
    if [ ! -f "$data/$f" ]; then
        echo "nav-hashes: missing $data/$f (set DATA=folder of the rtklib-drive-0708 files)" >&2
        exit 66
    fi
done
rm -rf "$out"
mkdir -p "$out"
out=$(cd "$out" && pwd)
"$bin" import-drive --imu "$data/imu_1934.csv" --tag "$data/imu_1934.csv.tag" \
    --pos "$data/gnss_1934_sf.pos" --out "$out/import" >/dev/null
lever=$(python3 -c 'import json,sys; print(",".join(str(x) for x in json.load(open(sys.argv[1]))["antenna_from_imu"]))' "$out/import/meta.json")
common=(nav --imu "$out/import/imu.csv" --gnss "$out/import/gnss.csv" --outages 40,15,45,30
    --model drive-datasheet --lever-arm "$lever")
bank=(--adapt --adapt-method bank)
run() {
    local name=$1
    shift
    "$bin" "${common[@]}" "$@" --out "$out/$name" >/dev/null 2>"$out/$name.log" ||
        { echo "nav-hashes: $name failed (see $out/$name.log)" >&2; exit 1; }
}
run bank "${bank[@]}"
run bank32 "${bank[@]}" --f32
run diag --identify --diagnose
run window --adapt
run bank60 "${bank[@]}" --adapt-every 60,60
run bank60-f32 "${bank[@]}" --adapt-every 60,60 --f32
run bank60-nhc "${bank[@]}" --adapt-every 60,60 --nhc 0.05
cd "$out"
find bank bank32 diag window bank60 bank60-f32 bank60-nhc -type f | sort | while read -r f; do
    printf '%s  %s\n' "$(sed -e "s#$out/##g" -e '/seconds/d' \
        -e 's#run time</td><td>[^<]*<#run time</td><td><#' "$f" | md5sum | cut -d' ' -f1)" "$f"
done >hashes.txt
echo "$(wc -l <hashes.txt) files hashed: $out/hashes.txt"
