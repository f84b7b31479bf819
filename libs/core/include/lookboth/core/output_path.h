// Where a command may write. Inputs are never written to: an output that is
// one of the inputs (the same file or folder however it is spelled, through
// "./", "..", symbolic or hard links) or that contains one (replacing it
// would delete the input) is refused, and an existing output is replaced
// only when the user said so.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace lookboth {

/// True when `a` and `b` name the same file or folder: the same inode when
/// both exist, else the same normalised absolute path.
bool sameFile(const std::filesystem::path& a, const std::filesystem::path& b);

/// True when `ancestor` is a folder that contains `path` (at any depth).
bool contains(const std::filesystem::path& ancestor, const std::filesystem::path& path);

/// Throws lookboth::Error naming `option` and the paths when `output` is or
/// contains one of `inputs`, or when it exists and `overwrite` is false
/// ("already exists (use --overwrite to replace it)").
void checkOutputPath(const std::filesystem::path& output,
                     const std::vector<std::filesystem::path>& inputs, bool overwrite,
                     const std::string& option = "--out");

}  // namespace lookboth
