// Bounded file reading (see visnav/file_io.hpp). POSIX open + fstat on the descriptor so the
// check and the read see the same file (no stat-then-open race with a swapped path).
#include "visnav/file_io.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace visnav {

namespace {

std::string errno_text(int err) { return std::strerror(err); }

/// Opens `path` read-only and checks type and size; returns the descriptor and the size.
Result<std::pair<int, std::uint64_t>> open_checked(const std::string& path, std::uint64_t max_bytes,
                                                   std::string_view kind) {
  const std::string what = std::string(kind) + " file";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT || err == ENOTDIR)
      return fail(ErrorCode::not_found, ErrorLocation{path}, "no such " + what);
    return fail(ErrorCode::io, ErrorLocation{path}, "cannot open " + what + ": " + errno_text(err));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    return fail(ErrorCode::io, ErrorLocation{path}, "cannot stat " + what + ": " + errno_text(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    const char* type = S_ISDIR(st.st_mode)   ? "a folder"
                       : S_ISCHR(st.st_mode) ? "a character device"
                       : S_ISBLK(st.st_mode) ? "a block device"
                       : S_ISFIFO(st.st_mode) ? "a pipe"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "not a regular file";
    return fail(ErrorCode::invalid_value, ErrorLocation{path},
                what + " is " + type + ", not a regular file; refused before reading");
  }
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size > max_bytes) {
    ::close(fd);
    return fail(ErrorCode::limit, ErrorLocation{path},
                what + " of " + std::to_string(size) + " bytes is larger than a " + std::string(kind) +
                    " file may be (" + std::to_string(max_bytes) + " bytes); refused before reading");
  }
  return std::pair<int, std::uint64_t>{fd, size};
}

}  // namespace

Result<std::string> read_text_file(const std::string& path, std::uint64_t max_bytes, std::string_view kind) {
  VISNAV_ASSIGN(const auto opened, open_checked(path, max_bytes, kind));
  const auto [fd, size] = opened;
  // O_NONBLOCK only mattered for opening (a FIFO without a writer); regular files ignore it.
  std::string text(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::read(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      return fail(ErrorCode::io, ErrorLocation{path}, "cannot read " + std::string(kind) + " file: " + errno_text(err));
    }
    if (n == 0) break;  // shrank while reading
    done += static_cast<std::size_t>(n);
  }
  // A file that grew while reading is cut at the size checked above: one more byte tells.
  char extra = 0;
  const bool grew = done == text.size() && ::read(fd, &extra, 1) > 0;
  ::close(fd);
  if (grew)
    return fail(ErrorCode::io, ErrorLocation{path}, std::string(kind) + " file changed while it was read; refused");
  text.resize(done);
  return text;
}

Status check_input_file(const std::string& path, std::uint64_t max_bytes, std::string_view kind) {
  VISNAV_ASSIGN(const auto opened, open_checked(path, max_bytes, kind));
  ::close(opened.first);
  return ok();
}

std::size_t first_invalid_utf8(std::string_view text) noexcept {
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  std::size_t i = 0;
  while (i < n) {
    const unsigned char c = s[i];
    if (c < 0x80) {
      ++i;
      continue;
    }
    std::size_t len = 0;
    unsigned lo = 0x80, hi = 0xBF;  // bounds of the second byte (Unicode Table 3-7)
    if (c >= 0xC2 && c <= 0xDF) {
      len = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      len = 3;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      len = 4;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    } else {
      return i;
    }
    if (i + len > n) return i;
    if (s[i + 1] < lo || s[i + 1] > hi) return i;
    for (std::size_t k = 2; k < len; ++k)
      if (s[i + k] < 0x80 || s[i + k] > 0xBF) return i;
    i += len;
  }
  return std::string_view::npos;
}

}  // namespace visnav
