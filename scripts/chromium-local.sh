#!/usr/bin/env bash
# Headless Chromium for the browser check of the HTML report (tests/report_html.rs).
#
#   scripts/chromium-local.sh install   install the Debian package `chromium` if
#                                       absent (root, apt-get); exit 0 when a
#                                       browser is on PATH
set -euo pipefail

say() { echo "chromium-local: $*" >&2; }
die() { say "$*"; exit 1; }

have() { command -v chromium >/dev/null || command -v chromium-browser >/dev/null \
    || command -v google-chrome >/dev/null; }

case "${1:-}" in
install)
    have && exit 0
    [ "$(id -u)" = 0 ] || die "no chromium on PATH and not root: cannot install it"
    command -v apt-get >/dev/null || die "no chromium on PATH and no apt-get to install it"
    say "installing chromium"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
    have || die "chromium installed but not on PATH"
    ;;
*)
    echo "usage: $0 install" >&2
    exit 2
    ;;
esac
