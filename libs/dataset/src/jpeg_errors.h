// libjpeg's errors as C++ exceptions (jpeg_errors.cpp says how and why).
#pragma once

#include <stdexcept>
#include <string>

namespace lookboth::internal {

/// What a corrupt JPEG raises inside any library's libjpeg decoding that
/// keeps libjpeg's default error handler (MRPT's rawlog images).
class JpegDecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The message of this thread's last JpegDecodeError, then forgets it: a
/// library that catches the exception and throws its own (MRPT's
/// deserialisation) loses libjpeg's words.
std::string takeJpegError();

/// Does nothing: the rawlog reader calls it so that jpeg_errors.cpp, whose
/// jpeg_std_error makes libjpeg's errors throw, is linked into every
/// executable that reads rawlogs.
void useThrowingJpegErrors();

}  // namespace lookboth::internal
