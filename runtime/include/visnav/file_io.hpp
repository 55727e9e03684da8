// visnav SDK — bounded reading of input files (configs, trees, worlds, routes, maps, marks,
// recorded runs).
//
// Every file the runtime or a plugin reads as a whole goes through read_text_file(): the file is
// opened, then fstat() on the open descriptor decides before a single byte is read — a path that
// is not a regular file (/dev/zero, /dev/urandom, a FIFO, a folder) and a regular file larger than
// the limit of its kind are refused with an error naming the path, so neither a device nor a
// runaway file can make the reader allocate without bound. The caller passes the limit of its
// kind (the constants below; a plugin chooses its own for its own formats).
//
// Thread-safety: the functions are pure apart from the file system access; any thread.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "visnav/result.hpp"

namespace visnav {

/// Size limits per file kind, bytes. Generous for real inputs (the shipped ones are < 100 kB
/// except maps' payload bodies, which the map store bounds by the size the graph declares).
inline constexpr std::uint64_t kMaxConfigFileBytes = 16ULL << 20;  ///< run configs, params, worlds, routes, marks
inline constexpr std::uint64_t kMaxTreeFileBytes = 8ULL << 20;     ///< behaviour-tree XML (one file)
inline constexpr std::uint64_t kMaxGraphFileBytes = 64ULL << 20;   ///< a map's graph.yaml
inline constexpr std::uint64_t kMaxTableFileBytes = 1ULL << 30;    ///< CSV / JSON logs of recorded runs
inline constexpr std::uint64_t kMaxImageFileBytes = 256ULL << 20;  ///< one image (texture, thumbnail, frame)

/// Reads the whole of `path` if it is a regular file of at most `max_bytes`. `kind` names the
/// file in messages ("config", "tree", "world", ...). Errors: not_found (no such file), io (open
/// or read refused), invalid_value (not a regular file), limit (larger than max_bytes).
[[nodiscard]] Result<std::string> read_text_file(const std::string& path, std::uint64_t max_bytes,
                                                 std::string_view kind);

/// The same checks without reading, for files a library opens itself (images for cv::imread).
[[nodiscard]] Status check_input_file(const std::string& path, std::uint64_t max_bytes, std::string_view kind);

/// Offset of the first byte of `text` that does not start a well-formed UTF-8 sequence (overlong
/// forms, surrogates and code points above U+10FFFF are ill-formed), or npos when it is all
/// well-formed.
[[nodiscard]] std::size_t first_invalid_utf8(std::string_view text) noexcept;

}  // namespace visnav
