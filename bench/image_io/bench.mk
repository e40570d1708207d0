# `make bench-image-io`: should common/image_io.cc (libpng and libjpeg-turbo
# called directly) give way to OpenImageIO or OpenCV's imgcodecs? The issue
# says replace it unless a benchmark shows the replacement slower.
#
#  - Decode in process, the same files with each decoder: ReadImage;
#    OpenImageIO's ImageInput into a BGR cv::Mat, by read_native_scanlines
#    and by read_image; cv::imread. The 7-Scenes kitchen's colour JPEGs and
#    16-bit depth PNGs, TUM fr1_xyz's colour JPEGs and the TUM colour PNGs
#    there are (fr1_desk, fr3_long_office_household: 11 files).
#    BENCH_IMAGE_IO_DECODES timed decodes each after a warm-up pass (median,
#    p95 ms), with glibc malloc's defaults and with its mmap and trim
#    thresholds fixed (bench_image_io.cc says why); pixels compared with
#    ReadImage's.
#  - Start-up: three probes (rrslam_common + ReadImage, + OpenImageIO,
#    + imgcodecs) each decode one PNG in a fresh process, BENCH_IMAGE_IO_STARTS
#    runs each with LD_BIND_NOW unset and set: wall and CPU time, split at
#    main() and the decode; ld.so's symbol relocations; ldd entries.
# Result: bench/results/image-io-<UTC date>[-BENCH_IMAGE_IO_TAG].txt (and .json).
BENCH_IMAGE_IO_DECODES ?= 200
BENCH_IMAGE_IO_STARTS ?= 20
BENCH_IMAGE_IO_TAG ?=
bench_image_io_sets := kitchen-rgb-jpeg:$(SHARED_DATA)/7scenes-kitchen/rgb.txt \
  kitchen-depth-png:$(SHARED_DATA)/7scenes-kitchen/depth.txt \
  fr1_xyz-rgb-jpeg:$(SHARED_DATA)/tum/fr1_xyz/rgb.txt \
  tum-rgb-png:$(SHARED_DATA)/tum/fr1_desk/rgb.txt \
  tum-rgb-png:$(SHARED_DATA)/tum/fr3_long_office_household/rgb.txt
# The sets whose list exists.
bench_image_io_present := $(foreach s,$(bench_image_io_sets),$(if \
  $(wildcard $(lastword $(subst :, ,$(s)))),$(s)))
bench_image_io_start_image := $(SHARED_DATA)/7scenes-kitchen/depth/1000000000.000000.png
# Recorded in the result: the command line that reproduces it.
bench_image_io_command = make bench-image-io BUILD_DIR=$(BUILD_DIR) \
  BENCH_IMAGE_IO_DECODES=$(BENCH_IMAGE_IO_DECODES) BENCH_IMAGE_IO_STARTS=$(BENCH_IMAGE_IO_STARTS)
bench_image_io_tools := bench_image_io bench_image_io_start_rrslam bench_image_io_start_oiio \
  bench_image_io_start_imgcodecs

.PHONY: bench-image-io
bench-image-io: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target $(bench_image_io_tools)
	@if [ ! -f "$(bench_image_io_start_image)" ]; then \
	  echo "bench-image-io: $(bench_image_io_start_image) not found, skipped"; exit 0; fi; \
	mkdir -p bench/results && \
	$(BUILD_DIR)/bench/bench_image_io $(foreach s,$(bench_image_io_present),--images $(s)) \
	  --decodes $(BENCH_IMAGE_IO_DECODES) --start-dir $(BUILD_DIR)/bench \
	  --start-image $(bench_image_io_start_image) --starts $(BENCH_IMAGE_IO_STARTS) \
	  --machine "$$(bench/machine.sh)" --command "$(bench_image_io_command)" \
	  --out bench/results/image-io-$$(date -u +%Y-%m-%d)$(if $(BENCH_IMAGE_IO_TAG),-$(BENCH_IMAGE_IO_TAG))

BENCH_TARGETS += bench-image-io
