#!/usr/bin/env bash
# Debian packages the tests need beside Python's: Chromium and ChromeDriver for the report's
# browser test (never a test tool's own browser download), and the libraries Open3D loads
# (libGL, OpenMP, libusb), GDAL's ogrinfo and CloudCompare (under xvfb-run), the real clients
# of the output files. Does nothing when all are there; needs root and apt otherwise.
set -euo pipefail
packages=()
command -v chromium >/dev/null || packages+=(chromium)
command -v chromedriver >/dev/null || packages+=(chromium-driver)
command -v ogrinfo >/dev/null || packages+=(gdal-bin)  # GDAL's own reader checks the GIS files
command -v CloudCompare >/dev/null || packages+=(cloudcompare)  # its command line checks regions.ply
command -v xvfb-run >/dev/null || packages+=(xvfb xauth)  # CloudCompare needs a display, even silent
for lib in libGL.so.1:libgl1 libgomp.so.1:libgomp1 libusb-1.0.so.0:libusb-1.0-0; do
    ldconfig -p 2>/dev/null | grep -q "${lib%%:*}" || packages+=("${lib##*:}")
done
[ ${#packages[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "installing Debian packages: ${packages[*]}"
    apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${packages[@]}" >/dev/null
else
    echo "note: missing Debian packages ${packages[*]} cannot be installed here (needs root and apt);" \
         "the tests that need them will be skipped."
fi
