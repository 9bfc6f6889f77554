#pragma once
// The scanning layer of the BVH reader: a cursor over the whole text that knows line numbers,
// whitespace-separated tokens and numbers. Borrowed views only: no allocation per token or line.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace mocap::io::bvh {

// What the parsing steps throw; parse_bvh turns it into a BvhError and nothing else sees it.
struct ParseError {
  int line = 0;
  std::string message;
};

// A word of the text and the 1-based line it starts on. Empty text means end of file.
struct Token {
  std::string_view text;
  int line = 0;
  bool end() const { return text.empty(); }
};

// Lines end at LF, CRLF or a lone CR (each counts as one line). Spaces, tabs, vertical tabs and
// form feeds separate tokens. In the hierarchy '{' and '}' are tokens of their own even when
// glued to a word ("Hips{").
class Cursor {
 public:
  explicit Cursor(std::string_view text);

  int line() const { return line_; }
  bool at_end() const { return p_ == end_; }
  std::size_t remaining() const { return std::size_t(end_ - p_); }

  // Skips whitespace and line breaks, then returns the next token (empty at end of file).
  Token next_token();
  // Skips spaces and tabs; true when the line ends here (line break or end of file).
  bool at_line_end();
  // The rest of the current line, trimmed, stopping before a '{' (a joint name may hold
  // spaces). Does not consume the line break.
  std::string_view rest_of_line_name();
  // Skips to the start of the next line (consuming the line break).
  void next_line();
  // The next token on the current line, or an empty token when the line ends first.
  Token token_on_line();
  // At end of file: the number of the file's last line (a final line break starts no new line).
  int final_line() const;

  // Raw access for the frame parser, which scans lines itself for speed.
  const char* position() const { return p_; }
  const char* end() const { return end_; }
  // Moves to `p` (not before the current position); `lines` is how many line breaks were passed.
  void advance_to(const char* p, int lines) {
    p_ = p;
    line_ += lines;
  }

 private:
  void skip_blank();  // spaces and tabs, not line breaks
  void skip_line_break();
  std::string_view scan_word(bool split_braces);

  const char* begin_;
  const char* p_;
  const char* end_;
  int line_ = 1;
};

inline bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}
inline bool is_line_break(char c) {
  return c == '\n' || c == '\r';
}
inline bool is_space(char c) {
  return is_blank(c) || is_line_break(c);
}

// Parses a whole token as a finite double: decimal or scientific, optional leading '+' or '-',
// ".5" and "-.5" accepted. Returns an explanation on failure ("'abc' is not a number").
struct NumberResult {
  double value = 0;
  const char* error = nullptr;  // nullptr on success; else "is not a number", "is not finite", ...
};
NumberResult parse_number(std::string_view token);

// Parses a whole token as a non-negative integer (digits only, optional '+').
std::optional<std::int64_t> parse_count(std::string_view token);

// A token fit for an error message: non-printable bytes escaped, long tokens cut.
std::string printable(std::string_view token);
// printable(token) in single quotes.
std::string quoted(std::string_view token);
// What was found where something else was expected: the quoted token, or "the end of the file".
std::string found(const Token& token);

// Case-insensitive ASCII comparison, for keywords.
bool equals_ignore_case(std::string_view a, std::string_view b);

}  // namespace mocap::io::bvh
