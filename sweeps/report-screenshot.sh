#!/bin/sh
# Opens a report in headless Chromium (Debian package `chromium`) and saves a screenshot:
#   sweeps/report-screenshot.sh docs/report.html docs/images/report.png
# Fails when the browser is missing, exits non-zero or writes no image.
set -eu
report=${1:?usage: report-screenshot.sh REPORT.html OUT.png}
out=${2:?usage: report-screenshot.sh REPORT.html OUT.png}
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
if [ -z "$browser" ]; then
    echo "no Chromium found: apt-get install -y chromium" >&2
    exit 2
fi
abs=$(cd "$(dirname "$report")" && pwd)/$(basename "$report")
rm -f "$out"
# --no-sandbox: containers often run as root, which Chromium's sandbox refuses.
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --window-size=1280,2000 --screenshot="$out" "file://$abs" >/dev/null 2>&1
if [ ! -s "$out" ]; then
    echo "Chromium wrote no screenshot of $report" >&2
    exit 1
fi
echo "wrote $out"
