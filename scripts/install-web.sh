#!/usr/bin/env bash
# Installs what the browser viewer and its tests need (issue 33, player/web):
# Debian's `chromium` (apt, when missing; ../shared/WEB.md has the flags) and the
# npm packages pinned in player/web/package-lock.json (esbuild, typescript, fzstd,
# playwright-core) into player/web/node_modules (git-ignored), then builds
# player/web/dist/viewer.js. Idempotent; `--no-apt` skips the apt step.
#   scripts/install-web.sh
set -euo pipefail
cd "$(dirname "$0")/../player/web"
if [ "${1:-}" != "--no-apt" ] && ! command -v chromium >/dev/null; then
    sudo_if() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
    sudo_if apt-get install -y -qq --no-install-recommends -o DPkg::Lock::Timeout=600 chromium \
        || { sudo_if apt-get update -qq && sudo_if apt-get install -y -qq --no-install-recommends chromium; }
fi
if ! command -v npm >/dev/null || ! command -v node >/dev/null; then
    echo "install-web.sh: node and npm are needed (Debian: apt-get install nodejs npm)" >&2
    exit 1
fi
if [ ! -d node_modules ] || [ package-lock.json -nt node_modules ]; then
    npm ci --no-audit --no-fund --loglevel=error
fi
npm run --silent build
echo "install-web.sh: viewer built (player/web/dist/viewer.js); chromium: $(command -v chromium || echo missing)"
