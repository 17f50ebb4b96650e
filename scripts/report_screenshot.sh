#!/usr/bin/env bash
# Render an HTML file (a `holecli report` page) to a PNG with headless chromium (Debian's `chromium`,
# which scripts/setup.sh installs), as the README's screenshot of a report is made:
#
#   scripts/report_screenshot.sh shift.html docs/images/report.png [WIDTH [HEIGHT]]
#
# WIDTH x HEIGHT is the browser window in CSS pixels (default 1280 x 2000): the PNG shows the top of
# the page at that size. $CHROMIUM names another browser binary. The browser runs with a throwaway
# profile, without a sandbox (it must run as root in containers), a GPU or background networking;
# the page itself loads nothing (its Content-Security-Policy forbids it). Exits non-zero with the
# browser's last messages when no PNG comes out.
set -euo pipefail

if [ $# -lt 2 ] || [ $# -gt 4 ]; then
    echo "usage: $0 PAGE.html OUT.png [WIDTH [HEIGHT]]" >&2
    exit 2
fi
page=$1
out=$2
width=${3:-1280}
height=${4:-2000}
chromium=${CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}
if [ -z "$chromium" ]; then
    echo "$0: chromium not found (apt-get install chromium, or scripts/setup.sh; or set CHROMIUM)" >&2
    exit 1
fi
if [ ! -f "$page" ]; then
    echo "$0: $page: no such file" >&2
    exit 1
fi
case $width$height in *[!0-9]*) echo "$0: WIDTH and HEIGHT are whole numbers of pixels" >&2; exit 2;; esac

url=$(python3 -c 'import pathlib, sys; print(pathlib.Path(sys.argv[1]).resolve().as_uri())' "$page")
out_abs="$(cd "$(dirname "$out")" && pwd)/$(basename "$out")"
profile=$(mktemp -d)
log=$(mktemp)
trap 'rm -rf "$profile" "$log"' EXIT
rm -f "$out_abs"
timeout 120 "$chromium" --headless --no-sandbox --disable-gpu --disable-background-networking \
    --hide-scrollbars --user-data-dir="$profile" --window-size="$width,$height" \
    --screenshot="$out_abs" "$url" >"$log" 2>&1 || true
if [ ! -s "$out_abs" ]; then
    echo "$0: chromium wrote no PNG; its last messages:" >&2
    tail -n 20 "$log" >&2
    exit 1
fi
echo "$out_abs: ${width}x${height} screenshot of $page" >&2
