#pragma once
// The HIERARCHY section of a BVH file: ROOT, JOINTs and End Sites into a Skeleton.
// Iterative with an explicit stack, so any nesting depth is safe.
#include "core/skeleton.hpp"
#include "io/bvh_lexer.hpp"

namespace mocap::io::bvh {

// Parses from the start of the text up to and including the root's closing brace; the cursor
// is left just after it. Throws ParseError for anything malformed.
Skeleton parse_hierarchy(Cursor& cursor);

}  // namespace mocap::io::bvh
