#!/usr/bin/env bash
# The real RTKLIB drive through the strapdown INS/GNSS filter with the README's outage test:
#   bash scripts/real-drive.sh OUT [extra `hal-sim nav` options, e.g. --model M.toml --adapt]
# 1. `hal-sim import-drive` turns ../shared/data/real/rtklib-drive-0708 (override with DATA=DIR)
#    into OUT/import/{imu.csv,gnss.csv,meta.json} (GPST seconds since 1980-01-06, SI, body FRD);
# 2. `hal-sim nav --imu OUT/import/imu.csv --gnss OUT/import/gnss.csv --outages 40,15,45,30
#    --out OUT [extra options]`, with `--model "$MODEL"` added when MODEL is set: GNSS withheld
#    15 s every 45 s from 40 s after the first epoch while the outage starts more than 30 s
#    before the last (11 outages), scored against the RTK fixes.
# When this build has no `nav` command yet, it stops after step 1 and says so (exit 2).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 1 ]; then
    echo "usage: bash scripts/real-drive.sh OUT [extra hal-sim nav options]" >&2
    exit 64
fi
out="$1"
shift
data="${DATA:-../shared/data/real/rtklib-drive-0708}"
for f in imu_1934.csv imu_1934.csv.tag gnss_1934_sf.pos; do
    if [ ! -f "$data/$f" ]; then
        echo "real-drive: missing $data/$f (set DATA=folder of the rtklib-drive-0708 files)" >&2
        exit 66
    fi
done
cargo build --release -q -j 2 -p hal-sim
bin=target/release/hal-sim
"$bin" import-drive --imu "$data/imu_1934.csv" --tag "$data/imu_1934.csv.tag" \
    --pos "$data/gnss_1934_sf.pos" --out "$out/import"
if ! "$bin" nav --help >/dev/null 2>&1; then
    echo "real-drive: imported into $out/import; this hal-sim has no 'nav' command yet (issue 16: the strapdown filter), so the run stops here" >&2
    exit 2
fi
args=(nav --imu "$out/import/imu.csv" --gnss "$out/import/gnss.csv" --outages 40,15,45,30 --out "$out")
[ -n "${MODEL:-}" ] && args+=(--model "$MODEL")
"$bin" "${args[@]}" "$@"
