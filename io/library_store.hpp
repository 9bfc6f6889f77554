#pragma once
// The HDF5 library store in one include: layout and names, compression, writer and reader.
#include "io/clip_encoder.hpp"
#include "io/compression.hpp"
#include "io/library_format.hpp"
#include "io/library_reader.hpp"
#include "io/library_writer.hpp"
