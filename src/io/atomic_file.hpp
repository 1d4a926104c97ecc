#pragma once
// Whole files written so that a reader (or a run resumed after a crash) sees either the
// old file or the new one, never half of one: written to <path>.tmp, flushed to disk, renamed.
#include <string>
#include <string_view>
#include <vector>

namespace fdem {

/// Writes text to path atomically; throws OutputError naming the file and the system's reason,
/// removing the temporary file.
void write_file_atomically(const std::string& path, const std::string& text);
/// The same for a file given in pieces, written one after the other (a checkpoint's header and
/// its payload's pieces, which are never joined into one string).
void write_file_atomically(const std::string& path, const std::vector<std::string_view>& pieces);

/// Why writing `path` failed with errno `err`, for messages: the system's reason and, where the
/// file system holding it has no room left, that the disk is full, how much is free and the fix.
std::string write_failure(const std::string& path, int err);

}  // namespace fdem
