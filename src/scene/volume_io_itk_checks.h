// sombra — checks of the ITK-read formats' headers that run before ITK reads them
// (src/scene/volume_io_itk_checks.cpp). Internal to src/scene.
#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include "scene/volume_io_common.h"

namespace sombra::volume_io {

// A NRRD (nrrd = true) or MetaImage header: its dimension count (1 … 4), its voxel sizes (finite,
// > 0) and the data files it names (one, a LIST, or a printf pattern with a range), each opened
// as an input (regular files only, relative to the header's folder). Returns the bytes the voxels
// can come from: the header file's own size when the data is attached, else the data files' sum.
// Throws "HEADER: FIELD: …".
std::uint64_t check_detached_header(const std::string& header, bool nrrd);

// Where a NRRD file's voxels lie, for reading a box of them (volume_io_parts.cpp): the data file
// (the header itself when attached), the byte at which its encoded data starts (after the header
// and the "line skip" lines), and "byte skip" (for gzip, counted in the decompressed stream; −1:
// the raw data ends the file). nullopt for encodings other than raw and gzip and for data split
// over several files (LIST or a pattern): such files are read whole. Throws "HEADER: FIELD: …".
struct NrrdDataLocation {
    std::string data_file;
    std::uint64_t start = 0;
    long long byte_skip = 0;
    bool gzip = false;
};
std::optional<NrrdDataLocation> nrrd_data_location(const std::string& header);

// Walks a TIFF's (or BigTIFF's) chain of image directories: throws "FILE: pages: …" for a loop,
// an offset or entry table past the end of the file, more than 65,536 pages, a tag given twice,
// a page without strips, with a codec other than none/LZW/Deflate/PackBits, with more than one
// sample per pixel or more voxels (with the pages before it) than max_voxels, or a page whose
// size, samples, bits or sample format differ from the first page's.
void check_tiff_pages(const std::string& path, std::uint64_t max_voxels);

// Walks a DICOM Part 10 file's data elements before GDCM parses it (volume_io_dicom_checks.cpp):
// the "DICM" preamble and file meta group, an uncompressed transfer syntax (implicit or explicit VR
// little endian; compressed ones are refused: GDCM's codecs abort on garbage), every element's and
// item's length inside the file and its enclosing item, undefined lengths only for sequences with
// their delimiters inside the file, and the image: Rows, Columns, BitsAllocated 8/16/32,
// SamplesPerPixel 1, NumberOfFrames, and PixelData at least rows × columns × frames × bytes long.
// Throws "FILE: FIELD: …". part10_only (a series folder's files): files without the "DICM" magic
// are left to GDCM's series scan, which skips what is not DICOM.
void check_dicom_file(const std::string& path, bool part10_only = false);

}  // namespace sombra::volume_io
