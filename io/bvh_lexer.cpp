#include "io/bvh_lexer.hpp"

#include <charconv>
#include <cmath>
#include <limits>

namespace mocap::io::bvh {

Cursor::Cursor(std::string_view text)
    : begin_(text.data()), p_(text.data()), end_(text.data() + text.size()) {}

void Cursor::skip_blank() {
  while (p_ != end_ && is_blank(*p_)) ++p_;
}

void Cursor::skip_line_break() {
  // CRLF is one line break; so is a lone CR (old Mac files) or a lone LF.
  if (*p_ == '\r' && p_ + 1 != end_ && p_[1] == '\n') ++p_;
  ++p_;
  ++line_;
}

std::string_view Cursor::scan_word(bool split_braces) {
  const char* start = p_;
  if (split_braces && (*p_ == '{' || *p_ == '}')) {
    ++p_;
  } else {
    while (p_ != end_ && !is_space(*p_) && !(split_braces && (*p_ == '{' || *p_ == '}'))) ++p_;
  }
  return {start, std::size_t(p_ - start)};
}

Token Cursor::next_token() {
  for (;;) {
    skip_blank();
    if (p_ == end_) return {{}, line_};
    if (!is_line_break(*p_)) break;
    skip_line_break();
  }
  const int line = line_;
  return {scan_word(true), line};
}

bool Cursor::at_line_end() {
  skip_blank();
  return p_ == end_ || is_line_break(*p_);
}

std::string_view Cursor::rest_of_line_name() {
  skip_blank();
  const char* start = p_;
  const char* last_word_end = p_;
  while (p_ != end_ && !is_line_break(*p_) && *p_ != '{' && *p_ != '}') {
    if (!is_blank(*p_)) last_word_end = p_ + 1;
    ++p_;
  }
  return {start, std::size_t(last_word_end - start)};
}

void Cursor::next_line() {
  while (p_ != end_ && !is_line_break(*p_)) ++p_;
  if (p_ != end_) skip_line_break();
}

Token Cursor::token_on_line() {
  if (at_line_end()) return {{}, line_};
  const int line = line_;
  return {scan_word(false), line};
}

int Cursor::final_line() const {
  if (p_ == end_ && p_ != begin_ && is_line_break(p_[-1])) return line_ - 1;
  return line_;
}

NumberResult parse_number(std::string_view token) {
  const char* first = token.data();
  const char* last = first + token.size();
  // std::from_chars takes no leading '+', but files written by printf("%+f") have them.
  if (last - first > 1 && *first == '+' &&
      ((first[1] >= '0' && first[1] <= '9') || first[1] == '.'))
    ++first;
  double value = 0;
  const auto [ptr, ec] = std::from_chars(first, last, value);
  if (ec == std::errc::result_out_of_range) return {0, "is out of range"};
  if (ec != std::errc() || ptr != last) return {0, "is not a number"};
  if (!std::isfinite(value)) return {0, "is not a finite number"};
  // Values end up as float32 (translations, the store): beyond its range they would be infinite.
  // What rounds to the largest float is in range: its shortest text, 3.4028235e+38 (which
  // export writes for it), reads as a double a little above it (a library_reader_fuzz finding).
  constexpr double kRoundsToAFiniteFloat = double(std::numeric_limits<float>::max()) + 0x1p103;
  if (!(std::abs(value) < kRoundsToAFiniteFloat))
    return {0, "is out of range (beyond the +-3.4e38 of a 32-bit float)"};
  return {value, nullptr};
}

std::optional<std::int64_t> parse_count(std::string_view token) {
  const char* first = token.data();
  const char* last = first + token.size();
  if (first != last && *first == '+') ++first;
  if (first == last || *first < '0' || *first > '9') return std::nullopt;
  std::int64_t value = 0;
  const auto [ptr, ec] = std::from_chars(first, last, value);
  if (ec != std::errc() || ptr != last) return std::nullopt;
  return value;
}

std::string printable(std::string_view token) {
  constexpr std::size_t kMaxShown = 32;
  std::string out;
  for (std::size_t i = 0; i < token.size() && i < kMaxShown; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += char(c);
    } else {
      constexpr char hex[] = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  if (token.size() > kMaxShown) out += "...";
  return out;
}

std::string quoted(std::string_view token) {
  // Appended piece by piece: "'" + std::string(...) trips a false -Wrestrict in GCC 12.
  std::string out = "'";
  out += printable(token);
  out += '\'';
  return out;
}

std::string found(const Token& token) {
  return token.end() ? std::string("the end of the file") : quoted(token.text);
}

bool equals_ignore_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = char(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = char(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

}  // namespace mocap::io::bvh
