// Each way a BVH file can be malformed gives one error that names the file and the 1-based line
// where the problem is, never a crash, a hang or a half-read clip.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "io/bvh_reader.hpp"

namespace mocap::io {
namespace {

// Line numbers of this text are cited by the tests below:
//  1 HIERARCHY   6 JOINT Leg   10 End Site   15 }             19 frame 1
//  2 ROOT Hips   7 {           11 {          16 MOTION        20 frame 2
//  3 {           8 OFFSET      12 OFFSET     17 Frames: 3     21 frame 3
//  4 OFFSET      9 CHANNELS    13 }          18 Frame Time:
//  5 CHANNELS                  14 }
const std::string kValid =
    "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition "
    "Zrotation Yrotation Xrotation\n\tJOINT Leg\n\t{\n\t\tOFFSET 1 -2 0.5\n\t\tCHANNELS 3 "
    "Zrotation Yrotation Xrotation\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 -3 0\n\t\t}\n\t}\n}\n"
    "MOTION\nFrames: 3\nFrame Time: 0.0083333\n"
    "1 2 3 10 20 30 -5 15 25\n"
    "1.5 2.5 3.5 11 21 31 -6 16 26\n"
    "2 3 4 12 22 32 -7 17 27\n";

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

int count_lines(const std::string& text) {
  int lines = 1;
  for (std::size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\n' || (text[i] == '\r' && (i + 1 == text.size() || text[i + 1] != '\n')))
      ++lines;
  return lines;
}

// Parses `text` as `name` and checks for exactly one error at `line` whose message holds
// `fragment` and reads "name:line: message".
void expect_error(const std::string& text, int line, const std::string& fragment,
                  const std::string& name = "walk.bvh") {
  const BvhReadResult result = parse_bvh(text, name);
  EXPECT_FALSE(result.clip);
  ASSERT_TRUE(result.error) << "no error for: " << text.substr(0, 80);
  EXPECT_EQ(result.error->file, name);
  EXPECT_EQ(result.error->line, line) << result.error->what();
  EXPECT_NE(result.error->message.find(fragment), std::string::npos) << result.error->what();
  EXPECT_EQ(result.error->what(), name + ":" + std::to_string(line) + ": " + result.error->message);
}

TEST(BvhMalformed, TheValidBaseTextParses) {
  const BvhReadResult result = parse_bvh(kValid, "walk.bvh");
  ASSERT_TRUE(result.clip);
  EXPECT_EQ(result.clip->frames, 3);
}

TEST(BvhMalformed, EmptyFile) {
  expect_error("", 1, "the file is empty");
  expect_error(" \n\t\n", 2, "the file is empty");
}

TEST(BvhMalformed, MissingMotion) {
  const std::string hierarchy_only = kValid.substr(0, kValid.find("MOTION"));
  expect_error(hierarchy_only, 15, "missing MOTION section after the hierarchy");
}

TEST(BvhMalformed, FewerFrameLinesThanFrames) {
  expect_error(replace(kValid, "Frames: 3", "Frames: 5"), 21,
               "the file ends after 3 frame lines, but 'Frames:' (line 17) says 5");
  // No frame line at all.
  expect_error(kValid.substr(0, kValid.find("1 2 3 10")), 18, "ends after 0 frame lines");
}

TEST(BvhMalformed, MoreFrameLinesThanFrames) {
  expect_error(replace(kValid, "Frames: 3", "Frames: 2"), 21,
               "more frame lines than the 2 that 'Frames:' (line 17) announces");
  // Blank lines after the last frame are not frames.
  const BvhReadResult trailing_blanks = parse_bvh(kValid + "\n  \n\t\n", "walk.bvh");
  EXPECT_TRUE(trailing_blanks.clip);
}

TEST(BvhMalformed, TooFewOrTooManyValuesOnAFrameLine) {
  expect_error(replace(kValid, "1.5 2.5 3.5 11 21 31 -6 16 26", "1.5 2.5 3.5 11 21 31 -6 16"), 20,
               "frame 2 has 8 values, expected 9");
  expect_error(replace(kValid, "1 2 3 10 20 30 -5 15 25", "1 2 3 10 20 30 -5 15 25 7"), 19,
               "frame 1 has 10 values, expected 9");
  expect_error(replace(kValid, "2 3 4 12 22 32 -7 17 27", "2"), 21,
               "frame 3 has 1 values, expected 9");
}

TEST(BvhMalformed, BlankLinesBetweenFramesKeepLineNumbersExact) {
  std::string text = replace(kValid, "2 3 4 12", "\n\n2 3 4 12");
  text = replace(text, "17 27", "17");
  expect_error(text, 23, "frame 3 has 8 values, expected 9");
}

TEST(BvhMalformed, CrlfCountsAsOneLine) {
  const std::string crlf = replace_all(kValid, "\n", "\r\n");
  expect_error(replace(crlf, "-6 16 26", "-6 16"), 20, "frame 2 has 8 values, expected 9");
  expect_error(replace(crlf, "Frames: 3", "Frames: 2"), 21, "more frame lines");
}

TEST(BvhMalformed, NonFiniteValuesNameTheToken) {
  expect_error(replace(kValid, "2.5 3.5 11", "nan 3.5 11"), 20,
               "frame 2, value 2: 'nan' is not a finite number");
  expect_error(replace(kValid, "2.5 3.5 11", "2.5 inf 11"), 20,
               "value 3: 'inf' is not a finite number");
  expect_error(replace(kValid, "2.5 3.5 11", "2.5 3.5 -Infinity"), 20,
               "value 4: '-Infinity' is not a finite number");
  expect_error(replace(kValid, "-7 17 27", "-7 17 1e999"), 21, "'1e999' is out of range");
}

TEST(BvhMalformed, NonNumericValuesNameTheToken) {
  expect_error(replace(kValid, "12 22 32", "12 abc 32"), 21,
               "frame 3, value 5: 'abc' is not a number");
  expect_error(replace(kValid, "12 22 32", "12 22 3,2"), 21, "'3,2' is not a number");
  expect_error(replace(kValid, "12 22 32", "12 1.2.3 32"), 21, "'1.2.3' is not a number");
  expect_error(replace(kValid, "12 22 32", "12 +-2 32"), 21, "'+-2' is not a number");
  expect_error(replace(kValid, "12 22 32", "12 0x1p3 32"), 21, "'0x1p3' is not a number");
  expect_error(replace(kValid, "OFFSET 1 -2 0.5", "OFFSET 1 two 0.5"), 8,
               "OFFSET value 'two' is not a number");
}

TEST(BvhMalformed, NonPositiveOrGarbageFrameTime) {
  for (const char* time : {"0", "-0.0083333", "abc", "nan", "inf", "0.01s"})
    expect_error(replace(kValid, "Frame Time: 0.0083333", std::string("Frame Time: ") + time), 18,
                 "the frame time '" + std::string(time) + "' is not a positive number of seconds");
  expect_error(replace(kValid, "Frame Time: 0.0083333", "Frame Time: 0.0083333 x"), 18,
               "unexpected 'x' after Frame Time");
  expect_error(replace(kValid, "Frame Time:", "Time:"), 18,
               "expected 'Frame Time:' after 'Frames:', found 'Time:'");
}

TEST(BvhMalformed, NegativeOrGarbageFrameCount) {
  for (const char* count : {"-3", "abc", "3.5", "1e3", "", "99999999999999999999"})
    expect_error(replace(kValid, "Frames: 3", std::string("Frames: ") + count), 17,
                 "the frame count '" + std::string(count) + "' is not a non-negative whole number");
  expect_error(replace(kValid, "Frames: 3\n", ""), 17, "expected 'Frames:' after MOTION");
}

TEST(BvhMalformed, UnknownChannelName) {
  expect_error(
      replace(kValid, "3 Zrotation Yrotation Xrotation", "3 Zrotation Wrotation Xrotation"), 9,
      "unknown channel 'Wrotation'");
}

TEST(BvhMalformed, ChannelsCountDoesNotMatchItsList) {
  expect_error(replace(kValid, "CHANNELS 3", "CHANNELS 4"), 9,
               "CHANNELS says 4 but lists 3 channels");
  expect_error(replace(kValid, "CHANNELS 6", "CHANNELS 5"), 5,
               "CHANNELS says 5 but lists 6 channels");
  expect_error(replace(kValid, "CHANNELS 3", "CHANNELS x"), 9,
               "the CHANNELS count 'x' is not a non-negative whole number");
}

TEST(BvhMalformed, ChannelSetsThatCannotBeRotationsOrPositions) {
  expect_error(replace(kValid, "3 Zrotation Yrotation Xrotation", "2 Zrotation Yrotation"), 9,
               "a joint needs 0 or 3 rotation channels, found 2");
  expect_error(
      replace(kValid, "3 Zrotation Yrotation Xrotation", "3 Zrotation Zrotation Xrotation"), 9,
      "channel Zrotation is listed twice");
  expect_error(replace(kValid, "6 Xposition Yposition Zposition", "5 Xposition Yposition"), 5,
               "a joint needs 0 or 3 position channels, found 2");
}

TEST(BvhMalformed, UnbalancedBraces) {
  expect_error(replace(kValid, "}\nMOTION", "}\n}\nMOTION"), 16,
               "unbalanced '}': the hierarchy was already closed on line 15");
  expect_error(replace(kValid, "\t}\n}\nMOTION", "\t}\nMOTION"), 15,
               "MOTION inside the hierarchy: joint 'Hips' (line 2) has no closing '}'");
  expect_error(replace(kValid, "JOINT Leg\n\t{", "JOINT Leg\n"), 8,
               "expected '{' after JOINT Leg, found 'OFFSET'");
  expect_error(replace(kValid, "\t\tEnd Site", "\t\t{\n\t\tEnd Site"), 10, "unexpected '{'");
}

TEST(BvhMalformed, MissingOffset) {
  expect_error(replace(kValid, "\t\tOFFSET 1 -2 0.5\n", ""), 13,
               "joint 'Leg' (line 6) has no OFFSET");
  expect_error(replace(kValid, "\t\t\tOFFSET 0 -3 0\n", ""), 12,
               "the End Site of joint 'Leg' (line 10) has no OFFSET");
  expect_error(replace(kValid, "OFFSET 1 -2 0.5", "OFFSET 1 -2"), 8,
               "OFFSET needs 3 numbers, found 'CHANNELS' on line 9");
  expect_error(replace(kValid, "OFFSET 0 -3 0", "OFFSET 0 -3"), 12,
               "OFFSET needs 3 numbers, found '}' on line 13");
  expect_error(kValid.substr(0, kValid.find("OFFSET 0 -3 0") + 8), 12,
               "OFFSET needs 3 numbers, found the end of the file");
}

TEST(BvhMalformed, SecondRootAndMisplacedBlocks) {
  expect_error(replace(kValid, "}\nMOTION", "}\nROOT Other\n{\nOFFSET 0 0 0\n}\nMOTION"), 16,
               "a second ROOT: only one ROOT is supported");
  expect_error(replace(kValid, "JOINT Leg", "ROOT Leg"), 6, "a second ROOT inside joint 'Hips'");
  expect_error(replace(kValid, "\t\t\tOFFSET 0 -3 0\n", "\t\t\tOFFSET 0 -3 0\nJOINT Toe\n{\n"), 13,
               "the End Site of joint 'Leg' (line 10) cannot have children");
  expect_error(
      replace(kValid, "\t}\n}\nMOTION", "\t\tEnd Site\n{\nOFFSET 0 1 0\n}\n\t}\n}\nMOTION"), 14,
      "joint 'Leg' has a second End Site");
  expect_error(replace(kValid, "\t\t\tOFFSET 0 -3 0\n", "\t\t\tOFFSET 0 -3 0\nCHANNELS 0\n"), 13,
               "an End Site has no CHANNELS");
  expect_error(replace(kValid, "ROOT Hips", "ROOT"), 2, "ROOT needs a name on the same line");
  expect_error(replace(kValid, "HIERARCHY\n", ""), 1,
               "expected HIERARCHY at the start of a BVH file, found 'ROOT'");
  expect_error(replace(kValid, "End Site", "End Sight"), 10, "expected 'Site' after 'End'");
  expect_error(replace(kValid, "\t\tEnd Site", "\t\tCHANNELS 0"), 10, "has a second CHANNELS");
}

TEST(BvhMalformed, TruncationInsideTheHierarchy) {
  const std::string cut = kValid.substr(0, kValid.find("\t\tCHANNELS 3"));
  expect_error(cut, 8, "the file ends inside the hierarchy: joint 'Leg' (line 6) is not closed");
  expect_error(kValid.substr(0, kValid.find("ROOT")), 1,
               "expected ROOT after HIERARCHY, found the end of the file");
  // Every cut inside the hierarchy is an error on a line the cut text has.
  const std::size_t motion = kValid.find("MOTION");
  for (std::size_t length = 0; length < motion; ++length) {
    const std::string text = kValid.substr(0, length);
    const BvhReadResult result = parse_bvh(text, "cut.bvh");
    ASSERT_TRUE(result.error) << "cut at " << length;
    EXPECT_FALSE(result.clip);
    EXPECT_GE(result.error->line, 1);
    EXPECT_LE(result.error->line, count_lines(text)) << result.error->what();
  }
}

TEST(BvhMalformed, BinaryGarbage) {
  const std::string png("\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0\x01\0", 20);
  expect_error(png, 1, "expected HIERARCHY at the start of a BVH file, found '\\x89PNG'");
  expect_error(std::string(4096, '\0'), 1, "found '\\x00\\x00\\x00");
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    std::string bytes(1 + rng() % 4096, '\0');
    for (char& c : bytes) c = char(rng() & 0xff);
    const BvhReadResult result = parse_bvh(bytes, "random.bin");
    ASSERT_TRUE(result.error) << "trial " << trial;
    EXPECT_EQ(result.error->file, "random.bin");
    EXPECT_GE(result.error->line, 1);
    EXPECT_LE(result.error->line, count_lines(bytes));
  }
}

TEST(BvhMalformed, RandomEditsOfAValidFileNeverCrash) {
  // Each edit either still parses or yields one error on a line the text has.
  std::mt19937_64 rng(11);
  const std::string pieces[] = {
      "{",          "}",   "\n", "\r\n", " ",      "JOINT X", "End Site",          "OFFSET",
      "CHANNELS 3", "nan", "-",  "1e",   "MOTION", "Frames:", std::string(1, '\0')};
  for (int trial = 0; trial < 3000; ++trial) {
    std::string text = kValid;
    for (int edit = 0; edit < 1 + int(rng() % 3); ++edit) {
      const std::size_t at = rng() % (text.size() + 1);
      switch (rng() % 3) {
        case 0:
          text.erase(at, 1 + rng() % 8);
          break;
        case 1:
          text.insert(at, pieces[rng() % std::size(pieces)]);
          break;
        default:
          if (at < text.size()) text[at] = char(rng() & 0xff);
      }
    }
    const BvhReadResult result = parse_bvh(text, "edit.bvh");
    ASSERT_NE(result.clip.has_value(), result.error.has_value()) << text;
    if (result.error) {
      EXPECT_GE(result.error->line, 1) << result.error->what();
      EXPECT_LE(result.error->line, count_lines(text)) << result.error->what();
      EXPECT_FALSE(result.error->message.empty());
    }
  }
}

TEST(BvhMalformed, UnreadableFileIsAnErrorWithoutALine) {
  const std::filesystem::path missing = "/nonexistent-dir/none.bvh";
  const BvhReadResult result = read_bvh(missing);
  EXPECT_FALSE(result.clip);
  ASSERT_TRUE(result.error);
  EXPECT_EQ(result.error->line, 0);
  EXPECT_EQ(result.error->what(),
            "/nonexistent-dir/none.bvh: cannot open the file: No such file or directory");
  const BvhReadResult directory = read_bvh(std::filesystem::temp_directory_path());
  ASSERT_TRUE(directory.error);
  EXPECT_EQ(directory.error->line, 0);
}

}  // namespace
}  // namespace mocap::io
