// libjpeg's errors as C++ exceptions, for every library of the process.
//
// MRPT decodes the JPEG images embedded in a rawlog while deserialising
// them, with libjpeg's default error handler, which prints libjpeg's message
// and calls exit(1): one corrupt image would end lookboth without its own
// message naming the file and the entry, and the desktop app with it. This
// file defines jpeg_std_error, which the dynamic linker binds in place of
// libjpeg's for every library of the executable. It installs libjpeg's
// defaults, then an error_exit that frees the decoder and throws
// JpegDecodeError; the rawlog reader reports it like any corrupt entry.
// Libraries that set an error_exit of their own (OpenCV, wxWidgets) do it
// after calling jpeg_std_error, as libjpeg's documentation asks, and keep it.
//
// The exception crosses libjpeg's C frames: Debian builds them with unwind
// tables (.eh_frame), and they hold nothing to clean up once jpeg_destroy
// has run.
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

// jpeglib.h needs size_t and FILE declared before it.
#include <jpeglib.h>

#include "jpeg_errors.h"

namespace lookboth::internal {

namespace {

using StdError = jpeg_error_mgr* (*)(jpeg_error_mgr*);

/// libjpeg's own jpeg_std_error, the next definition after this one.
StdError libjpegStdError() {
  static const StdError real = [] {
    void* symbol = dlvsym(RTLD_NEXT, "jpeg_std_error", "LIBJPEG_6.2");
    if (!symbol) symbol = dlsym(RTLD_NEXT, "jpeg_std_error");
    if (!symbol) {
      std::fputs("lookboth: libjpeg's jpeg_std_error not found in the process\n", stderr);
      std::abort();
    }
    return reinterpret_cast<StdError>(symbol);
  }();
  return real;
}

thread_local std::string t_last_error;

[[noreturn]] void throwingErrorExit(j_common_ptr decoder) {
  char text[JMSG_LENGTH_MAX] = {};
  decoder->err->format_message(decoder, text);
  jpeg_destroy(decoder);
  t_last_error = std::string("corrupt JPEG image (libjpeg: ") + text + ")";
  throw JpegDecodeError(t_last_error);
}

}  // namespace

std::string takeJpegError() {
  std::string error;
  error.swap(t_last_error);
  return error;
}

void useThrowingJpegErrors() {}

}  // namespace lookboth::internal

extern "C" jpeg_error_mgr* jpeg_std_error(jpeg_error_mgr* err) {
  lookboth::internal::libjpegStdError()(err);
  err->error_exit = &lookboth::internal::throwingErrorExit;
  return err;
}
