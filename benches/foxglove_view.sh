#!/usr/bin/env bash
# docs/images/foxglove.png: the node's live view as the Foxglove app shows it, rendered headless.
# The app is @foxglove/studio-base 1.48.0's prebuilt bundle (npm) in the system's Chromium
# (installed with apt when missing), with docs/foxglove-layout.json as its layout; it speaks
# foxglove.websocket.v1, the protocol's earlier name (vendor/foxglove/README.physskin.md).
# `physskin node --foxglove` runs the workcell scene, and the picture is taken after the layout's
# Poke button was pressed; everything runs in a private network namespace.
# Needs root. Usage: benches/foxglove_view.sh [SECONDS before the picture, default 20]
set -euo pipefail
cd "$(dirname "$0")/.."
wait_s=${1:-20}
dir=target/foxglove-view
page=$dir/page
mkdir -p "$page"
command -v chromium > /dev/null || {
    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium
}
unpack() { # npm package, then the folder it lands in under $dir
    [ -d "$dir/$2" ] && return
    (cd "$dir" && tgz=$(npm pack --silent "$1") && mkdir -p "$2" &&
        tar -xzf "$tgz" -C "$2" --strip-components 1 && rm "$tgz")
}
unpack @foxglove/studio-base@1.48.0 studio-base
unpack react@17.0.2 react
unpack react-dom@17.0.2 react-dom
[ -d "$dir/node_modules/puppeteer-core" ] ||
    (cd "$dir" && npm install --silent --no-save --no-package-lock puppeteer-core@23)
mkdir -p "$page/react" "$page/react-dom"
cp benches/peers/foxglove_view.html "$page/index.html"
cp docs/foxglove-layout.json "$page/layout.json"
cp "$dir/react/umd/react.production.min.js" "$page/react/"
cp "$dir/react-dom/umd/react-dom.production.min.js" "$page/react-dom/"
ln -sfn "$(pwd)/$dir/studio-base/assets" "$page/assets"
out=docs/images/foxglove.png
unshare -n tests/peers/private_net.sh bash -c "
    target/release/physskin node --domain-id 44 --scene config/scenes/workcell.yaml \
        --foxglove 127.0.0.1:8765 > $dir/node.log 2>&1 & node=\$!
    python3 -m http.server 8099 --bind 127.0.0.1 --directory $page > $dir/http.log 2>&1 & http=\$!
    sleep 2
    NODE_PATH=$dir/node_modules node benches/peers/foxglove_shot.js \
        'http://127.0.0.1:8099/index.html?ds=foxglove-websocket&ds.url=ws://127.0.0.1:8765&layoutId=physskin' \
        $out $((wait_s * 1000)); rc=\$?
    kill \$http; kill -INT \$node; wait \$node
    exit \$rc"
echo "wrote $out"
