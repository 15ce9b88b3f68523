#!/usr/bin/env bash
# Debian's Chromium and ChromeDriver for the report's end-to-end test (never a test tool's
# own browser download). Does nothing when both are already there.
set -euo pipefail
if command -v chromium >/dev/null && command -v chromedriver >/dev/null; then
    exit 0
fi
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "installing Debian's chromium and chromium-driver for the browser test..."
    apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null
else
    echo "note: chromium and chromedriver are missing and cannot be installed here (needs root and apt);" \
         "the browser test will be skipped. Install Debian's 'chromium' and 'chromium-driver' to run it."
fi
