// The OpenCV ArUco dictionary behind a MarkerSpec::dictionary name, for the
// simulator (drawing the marker) and the detector (finding it).
#pragma once

#include <string>

namespace lookboth {

/// OpenCV's cv::aruco::PREDEFINED_DICTIONARY_NAME value of a dictionary name
/// ("DICT_4X4_50"); throws lookboth::Error naming 'dictionary' for an unknown name.
int arucoDictionaryId(const std::string& name);

}  // namespace lookboth
