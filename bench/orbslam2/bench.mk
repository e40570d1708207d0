# `make bench-orbslam2 ORBSLAM2_RGBD_TUM=/path/to/ORB_SLAM2/Examples/RGB-D/rgbd_tum`:
# ORB-SLAM2 itself on bench-track's sequences, vocabularies and settings
# (bench/orbslam2/run.sh), BENCH_ORBSLAM2_RUNS runs of each, so that rrslam's
# figures in bench/results/track-*.txt read against the system it follows.
# ORB-SLAM2 is not part of rrslam: build raulmur/ORB_SLAM2 yourself (its
# viewer can be left out; docs/track.md says how it was built for the
# committed results). Not part of `make bench`, which must run without it.
ORBSLAM2_RGBD_TUM ?=
BENCH_ORBSLAM2_RUNS ?= 3

.PHONY: bench-orbslam2
bench-orbslam2: configure
	@test -n "$(ORBSLAM2_RGBD_TUM)" || { echo "bench-orbslam2: set ORBSLAM2_RGBD_TUM to ORB-SLAM2's rgbd_tum" >&2; exit 64; }
	cmake --build $(BUILD_DIR) -j $(JOBS) --target $(bench_track_tools)
	$(MAKE) --no-print-directory bench-track-data
	@mkdir -p bench/results
	bench/orbslam2/run.sh $(ORBSLAM2_RGBD_TUM) $(BIN) $(BENCH_TRACK_DIR) $(SHARED_DATA) \
	  $(BENCH_ORBSLAM2_RUNS) bench/results/orbslam2-$$(date -u +%Y-%m-%d)
