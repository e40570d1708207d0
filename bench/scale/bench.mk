# `make bench-scale`: maps at 1k, 3k and 10k keyframes (issue 35), composed
# from a real map (copies on a 20 m grid, descriptors perturbed by 64 bits,
# bags of words recomputed with the map's vocabulary;
# stages/mapstore/map_compose.h): file size per keyframe, save, load in
# process, `rrslam-mapstore verify` as a whole process with its peak memory;
# then BENCH_SCALE_STARTS cold starts of `rrslam-track --load-map
# --localization-only` on the base map and on each composed one (frames
# 500, 600, ... of the base map's sequence, 100 frames each: first pose
# after process start, every relocalization attempt, tracking median, peak
# memory) and one run mapping on it from frame 500, 300 frames (restore
# mapping: local mapping's median over the 5 keyframes they add), and in
# process relocalization attempts on every 10th of frames 500-999 (the p95
# goal's figure). Goals at 10k keyframes: load <= 1.5 s, peak memory
# <= 2x the file, save <= 2 s, verify <= 1 s, first pose <= 2 s,
# relocalization p95 <= 30 ms, tracking median <= 1.2x and local mapping
# <= 1.5x the base map's (measured by the same runs on the base map, each
# just before the composed map's, so both see the machine of those minutes).
# Then revisits: three laps of rrslam-synth's
# standard room mapped in one run, and the base map's sequence's frames
# 0-299 twice (bench/track/make_kidnapped.sh), each with the defaults
# (revisit keyframes culled after the last frame), with --no-cull-revisits
# (ORB-SLAM2's keyframes) and with --new-view-fraction 0.15 instead: the
# keyframes left by pass (the later passes add at most 10% of the first's).
# On the base map and every composed map, loop closing's essential graph
# after a made-up loop, and on those of up to 3k keyframes its global BA,
# each on a thread of its own while a camera is localized in the map at 30
# Hz (goal at 3k keyframes and more: tracking p95 during it within 1.5x of
# before). Then the building: BENCH_SCALE_BUILDING_FRAMES frames of
# rrslam-synth's building tour (one tour: 6675; 0: skipped) mapped in one
# run with --save-map; over whole tours (20025: three), the keyframes each
# tour leaves (the second and third revisit the first's rooms). About 25
# minutes (the building's rendering ~6, its run ~3); the 10k map takes ~1.1 GB of disk in BENCH_SCALE_DIR while it is
# measured, the building's sequence ~6 GB (kept for the next run).
#
# The base map: BENCH_SCALE_MAP, by default bench-dense's kitchen map
# (frames [0, 500), made as bench-dense makes it when missing), with its
# vocabulary BENCH_SCALE_VOCAB.
# Result: bench/results/scale-<UTC date>[-BENCH_SCALE_TAG].txt (and .json),
# and the curves against keyframes in ...-time.png, ...-memory.png,
# ...-track.png, ...-global-ba.png and ...-global-ba-tracking.png.
BENCH_SCALE_DIR ?= $(BUILD_DIR)/bench-data/scale
BENCH_SCALE_MAP ?= $(BENCH_DENSE_MAP)
BENCH_SCALE_VOCAB ?= $(bench_dense_pipeline)/7scenes-kitchen/voc.rrv
BENCH_SCALE_SIZES ?= 1000,3000,10000
BENCH_SCALE_TAG ?=
BENCH_SCALE_STARTS ?= 3
BENCH_SCALE_BUILDING_FRAMES ?= 6675

.PHONY: bench-scale
bench-scale: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-mapstore rrslam-track rrslam-synth bench_scale
	@if [ ! -f "$(BENCH_DENSE_SEQUENCE)/rgb.txt" ] && [ ! -f "$(BENCH_SCALE_MAP)" ]; then \
	  echo "bench-scale: no base map and no $(BENCH_DENSE_SEQUENCE) to make one, skipped"; exit 0; fi; \
	$(MAKE) --no-print-directory $(BENCH_SCALE_MAP) && mkdir -p bench/results $(BENCH_SCALE_DIR) && \
	replay=$(BENCH_SCALE_DIR)/$(notdir $(BENCH_DENSE_SEQUENCE))-frames-0-299-twice && \
	bench/track/make_kidnapped.sh $(BENCH_DENSE_SEQUENCE) 0 300 0 300 $$replay && \
	$(BUILD_DIR)/bench/bench_scale --map $(BENCH_SCALE_MAP) --vocab $(BENCH_SCALE_VOCAB) \
	  --mapstore $(BIN)/rrslam-mapstore --work $(BENCH_SCALE_DIR) --sizes $(BENCH_SCALE_SIZES) \
	  --track $(BIN)/rrslam-track --sequence $(BENCH_DENSE_SEQUENCE) --settings $(BENCH_DENSE_SETTINGS) \
	  --starts $(BENCH_SCALE_STARTS) --synth $(BIN)/rrslam-synth \
	  --replay $$replay \
	  --building-frames $(BENCH_SCALE_BUILDING_FRAMES) \
	  --machine "$$(bench/machine.sh)" \
	  --out bench/results/scale-$$(date -u +%Y-%m-%d)$(if $(BENCH_SCALE_TAG),-$(BENCH_SCALE_TAG))

BENCH_TARGETS += bench-scale
