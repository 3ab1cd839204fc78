# SPDX-License-Identifier: MIT
# Fresh machines (mk/fresh-root.sh): the README's commands in new minimal
# Debian roots, isolated, reaching only the Debian archive and PyPI
# through a proxy (mk/fresh-proxy.py):
#   check-fresh   (in make check) on bookworm and on trixie
#                 `DEPS_YES=1 make demo` passes and shows the demo; on a
#                 bookworm older than the archive (bookworm-old)
#                 `DEPS_YES=1 make test-deps` passes. The roots are cached in
#                 /var/cache/drgate/roots (remade after 7 days), apt's
#                 downloads in /var/cache/drgate/apt-SUITE. Logs in
#                 $(B)/fresh/. SKIPPED without root, mmdebstrap or unshare
#                 (a failure under CI).
#   fresh-roots   makes (or refreshes) the cached roots
# Other steps run in such a root with
#   sh mk/fresh-root.sh run SUITE -- COMMAND...
# In make check beside the other steps (CHECK_BG_STEPS): about 10 minutes
# warm, mostly waiting on dpkg and the suites in the roots.
CHECK_BG_STEPS += check-fresh

check-fresh:
	@sh mk/fresh-root.sh check $(B) "$(RESULTS)"

fresh-roots:
	@sh mk/fresh-root.sh build bookworm trixie bookworm-old

.PHONY: check-fresh fresh-roots
