#!/usr/bin/env bash
# Installs Debian's Chromium, which the report test opens the HTML report in (headless).
# Needs apt and root; elsewhere it says what to install and the test skips with that.
set -euo pipefail
for name in chromium chromium-browser google-chrome; do
    command -v "$name" >/dev/null && exit 0
done
if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    export DEBIAN_FRONTEND=noninteractive
    install() { apt-get install -y -qq --no-install-recommends chromium >/dev/null; }
    install || { apt-get update -qq && install; } ||
        echo "browser-deps: apt could not install chromium; the report's browser test" \
            "will skip" >&2
else
    echo "browser-deps: no Chromium and no root apt to install it: install chromium" \
        "to run the report's browser test" >&2
fi
