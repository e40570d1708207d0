// The viewer script embedded at build time: viewer/viewer.js bundled with
// three.js by esbuild (one minified IIFE), written as a byte array into a
// generated source by cmake/EmbedFile.cmake. Internal to html_viewer.cc
// (public access: ViewerScript() in html_viewer.h).
#pragma once

#include <cstddef>

namespace rrslam::html_internal {

extern const unsigned char kViewerScript[];  // UTF-8, not NUL-terminated.
extern const std::size_t kViewerScriptSize;  // Bytes.

}  // namespace rrslam::html_internal
