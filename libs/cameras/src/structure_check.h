// Checks of a calibration file's structure, made before a parser builds it
// (private to the cameras library): how deep its collections nest, and
// whether a map holds a key twice.
//
// cv::FileStorage's readers recurse once per nesting level with no bound, so
// a few hundred kilobytes of "[[[[" overflow the stack and kill the process;
// yaml-cpp stops at a depth of its own but says only "bad file". Both keep a
// repeated key and answer a lookup with the first one, so the second would be
// ignored without a word.
#pragma once

#include <string>

namespace lookboth {

/// The deepest nesting of collections a calibration file may have. The
/// formats lookboth reads nest three levels (OpenCV's root map, a matrix, its
/// data); a file far past that is broken or hostile.
inline constexpr int kMaxCalibrationNesting = 64;

/// A key or name from a file, cut to 60 characters ("..." added) for the
/// field or subject of an error message: in a broken file it may be a whole
/// line of megabytes. (Values in a message go through lookboth::excerpt.)
std::string shortenedName(const std::string& name);

/// For YAML that yaml-cpp will load (lookboth, ROS camera_info, Kalibr; the
/// first document, as YAML::Load reads). Throws lookboth::Error naming `file`
/// and the line when collections nest deeper than `max_depth`, or naming the
/// key too when a map holds a key twice. Syntax errors propagate as yaml-cpp's
/// exceptions.
void checkYamlStructure(const std::string& text, const std::string& file,
                        int max_depth = kMaxCalibrationNesting);

/// For text cv::FileStorage will read (YAML, XML or JSON, told apart as OpenCV
/// does, by the first characters). Throws lookboth::Error naming `file` and the
/// line when OpenCV's reader would nest collections deeper than `max_depth`,
/// when a map holds a key twice (naming the key), or when the reader would
/// crash, never finish, or read memory the text never filled. Text the reader
/// rejects with a parse error of its own passes: OpenCV reports it.
void checkFileStorageStructure(const std::string& text, const std::string& file,
                               int max_depth = kMaxCalibrationNesting);

}  // namespace lookboth
