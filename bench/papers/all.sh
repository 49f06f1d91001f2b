#!/usr/bin/env bash
# Every paper-figure sweep, one after the other (see docs/reproducing-the-papers.md).
set -euo pipefail
here=$(dirname "$0")
for s in xie2007-fig4 sintorn2008-fig12 sintorn2008-fig13 agrawala2000-fig10 eisemann2006-light-size; do
  "$here/$s.sh"
done
