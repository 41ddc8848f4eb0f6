#!/usr/bin/env bash
# The real RTKLIB drive through the strapdown INS/GNSS filter with the README's outage test:
#   bash scripts/real-drive.sh OUT [extra `hal-sim nav` options, e.g. --model M.toml --adapt]
# 1. `hal-sim import-drive` turns ../shared/data/real/rtklib-drive-0708 (override with DATA=DIR)
#    into OUT/import/{imu.csv,gnss.csv,meta.json} (GPST seconds since 1980-01-06, SI, body FRD);
# 2. `hal-sim nav --imu OUT/import/imu.csv --gnss OUT/import/gnss.csv --outages 40,15,45,30
#    --model "${MODEL:-drive-datasheet}" --lever-arm <antenna from IMU, from meta.json>
#    --out OUT [extra options]`: GNSS withheld 15 s every 45 s from 40 s after the first epoch
#    while the outage starts more than 30 s before the last (11 outages), scored against the
#    RTK fixes (OUT/summary.json, OUT/outages.json); the solution is OUT/solution.pos.
#    The three runs of issue 16: no extra option (datasheet), MODEL=drive-inflated, and
#    `--identify` (the noise identified on the log by maximum likelihood); online, causally:
#    MODEL=drive-inflated bash scripts/real-drive.sh OUT --adapt --adapt-every 60,60.
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
lever=$(python3 -c 'import json,sys; print(",".join(str(x) for x in json.load(open(sys.argv[1]))["antenna_from_imu"]))' "$out/import/meta.json")
args=(nav --imu "$out/import/imu.csv" --gnss "$out/import/gnss.csv" --outages 40,15,45,30
    --model "${MODEL:-drive-datasheet}" --lever-arm "$lever" --out "$out")
"$bin" "${args[@]}" "$@"
