// sombra — medical image formats through ITK's ImageIO: NRRD, MetaImage, TIFF stacks, DICOM
// (one file, or a folder holding a series, through GDCM). The only file that includes ITK's
// headers (they take ~20 s of CPU to compile: keep them here), with writers for test data.
//
// ITK places images in LPS millimetres (DICOM's patient frame); sombra's world for medical images
// is RAS (NIfTI's and 3D Slicer's), so x and y change sign. A TIFF has no patient frame: its stack
// is placed as stored (identity), centred at the origin.
#include "scene/volume_io_common.h"

#include "scene/input_file.h"
#include "scene/stderr_capture.h"
#include "scene/volume_io_itk_checks.h"

#if defined(__clang__)
// Debian's ITK 5.2 generated its compiler-detection header for GCC only: under clang (the sanitizer
// build) it stops with "Unsupported compiler". Read it once as GCC 12 (its feature macros only);
// its include guard keeps it so for the ITK headers below.
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Wbuiltin-macro-redefined"
#pragma push_macro("__clang__")
#pragma push_macro("__GNUC__")
#pragma push_macro("__GNUC_MINOR__")
#undef __clang__
#undef __GNUC__
#undef __GNUC_MINOR__
#define __GNUC__ 12  // clang says 4.2, which the header refuses; C++17 clang has every feature it asks
#define __GNUC_MINOR__ 2
#include <itk_compiler_detection.h>
#pragma pop_macro("__GNUC_MINOR__")
#pragma pop_macro("__GNUC__")
#pragma pop_macro("__clang__")
#pragma clang diagnostic pop
#endif
#include <gdcmTrace.h>
#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageSeriesReader.h>
#include <itkMetaDataObject.h>
#include <itkMetaImageIO.h>
#include <itkNrrdImageIO.h>
#include <itkTIFFImageIO.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>

#include <unistd.h>

namespace sombra::volume_io {
namespace {

using Image = itk::Image<float, 3>;
namespace fs = std::filesystem;

// At most this many DICOM files in a series folder, and this many voxel bytes per byte of input
// (deflate, the densest codec these formats use, stops near 1032:1): a header that promises more
// than its file can hold is refused before ITK allocates the buffer.
constexpr std::size_t kMaxSeriesFiles = 100000;
constexpr std::uint64_t kMaxInflation = 1100;

void quiet_once() {
    static std::once_flag flag;
    // ITK prints warnings (odd DICOM tags, uneven slices) to stderr: sombra reports its own
    std::call_once(flag, [] {
        itk::Object::GlobalWarningDisplayOff();
        gdcm::Trace::SetDebug(false);  // GDCM's own warnings and errors: the exception says enough
        gdcm::Trace::SetWarning(false);
        gdcm::Trace::SetError(false);
    });
}

// The voxel type as sombra's readers hold it; nullopt for the 64-bit integers.
std::optional<ScalarType> scalar_type(const itk::ImageIOBase& io) {
    using C = itk::IOComponentEnum;
    switch (io.GetComponentType()) {
        case C::UCHAR: return ScalarType::u8;
        case C::CHAR: return ScalarType::i8;
        case C::USHORT: return ScalarType::u16;
        case C::SHORT: return ScalarType::i16;
        case C::UINT: return ScalarType::u32;
        case C::INT: return ScalarType::i32;
        case C::FLOAT: return ScalarType::f32;
        case C::DOUBLE: return ScalarType::f64;
        default: return std::nullopt;
    }
}

// ITK's component type as Volume::stored_type spells it ("uint8", "int16", "float32", …).
std::string stored_type_name(const itk::ImageIOBase& io) {
    using C = itk::IOComponentEnum;
    if (const std::optional<ScalarType> type = scalar_type(io)) return type_name(*type);
    switch (io.GetComponentType()) {
        case C::ULONG: case C::ULONGLONG: return "uint64";
        case C::LONG: case C::LONGLONG: return "int64";
        default: return "";
    }
}

itk::ImageIOBase::Pointer make_io(ItkFormat format) {
    switch (format) {
        case ItkFormat::nrrd: return itk::NrrdImageIO::New().GetPointer();
        case ItkFormat::metaimage: return itk::MetaImageIO::New().GetPointer();
        case ItkFormat::tiff: return itk::TIFFImageIO::New().GetPointer();
        case ItkFormat::dicom:
        case ItkFormat::dicom_series: return itk::GDCMImageIO::New().GetPointer();
    }
    return nullptr;
}

const char* format_name(ItkFormat format) {
    switch (format) {
        case ItkFormat::nrrd: return "NRRD";
        case ItkFormat::metaimage: return "MetaImage";
        case ItkFormat::tiff: return "TIFF";
        case ItkFormat::dicom:
        case ItkFormat::dicom_series: return "DICOM";
    }
    return "";
}

// Checks what the header (of the first file) declares, before any voxel is read.
void check_header(const std::string& path, itk::ImageIOBase& io, std::size_t slices, std::uint64_t input_bytes,
                  const VolumeLoadOptions& options, std::uint64_t voxel_limit = limits::kMaxVolumeVoxels) {
    const unsigned n = io.GetNumberOfDimensions();
    std::array<long long, 3> dims{1, 1, 1};
    for (unsigned d = 0; d < n; ++d) {
        const long long size = static_cast<long long>(io.GetDimensions(d));
        if (d < 3) dims[d] = size;
        else if (size != 1)
            throw file_error(path, "dims", "a " + std::to_string(n) + "-D image (dimension " + std::to_string(d) +
                                               " has " + std::to_string(size) + " samples); expected 3-D");
    }
    if (slices > 1) {
        if (n >= 3 && dims[2] != 1)
            throw file_error(path, "dims", "a series of 3-D files (" + std::to_string(dims[2]) + " frames each)");
        dims[2] = static_cast<long long>(slices);
    }
    if (io.GetNumberOfComponents() != 1)
        throw file_error(path, "components", std::to_string(io.GetNumberOfComponents()) +
                                                 " components per voxel (colour or vector data); expected one (grey)");
    const std::size_t count = checked_voxel_count(path, dims, voxel_limit);
    if (count > options.max_voxels)
        throw file_error(path, "dims", std::to_string(count) + " voxels exceed the limit of " +
                                           std::to_string(options.max_voxels));
    const std::uint64_t bytes = std::uint64_t(count) * std::uint64_t(io.GetComponentSize());
    if (bytes / kMaxInflation > input_bytes)
        throw file_error(path, "data", "truncated: the header declares " + std::to_string(bytes) +
                                           " bytes of voxels, more than " + std::to_string(input_bytes) +
                                           " bytes of input can hold");
}

// The regular files of a series folder; refuses anything else that could block or mislead.
std::vector<std::string> folder_files(const std::string& dir, std::uint64_t* total_bytes) {
    std::vector<std::string> files;
    *total_bytes = 0;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const fs::file_status st = it->symlink_status(ec);
        if (ec) break;
        if (fs::is_directory(st)) continue;  // not searched: one series per folder
        if (!fs::is_regular_file(st))
            throw file_error(dir, "", "holds '" + it->path().filename().string() +
                                          "', which is not a regular file (a DICOM series folder holds regular files only)");
        if (files.size() == kMaxSeriesFiles)
            throw file_error(dir, "", "holds more than " + std::to_string(kMaxSeriesFiles) + " files");
        files.push_back(it->path().string());
        const std::uint64_t size = it->file_size(ec);
        *total_bytes += size;
        check_dicom_file(files.back(), true);  // before GDCM's series scan parses it
    }
    if (ec) throw file_error(dir, "", "cannot list the folder: " + ec.message());
    if (files.empty()) throw file_error(dir, "", "an empty folder (expected the files of one DICOM series)");
    return files;
}

// The geometry a DICOM file's header declares, as numbers: ImagePositionPatient (0020,0032),
// ImageOrientationPatient (0020,0037), PixelSpacing (0028,0030); empty where a tag is absent.
struct DicomGeometry {
    std::vector<double> position, orientation, spacing;
};

// "a\\b\\c" (DICOM's decimal strings, backslash-separated) → numbers; throws naming the tag when a
// value is not a finite number or the count is wrong.
std::vector<double> dicom_numbers(const itk::MetaDataDictionary& dict, const char* tag, const char* name,
                                  std::size_t count, const std::string& file) {
    std::string text;
    if (!itk::ExposeMetaData<std::string>(dict, tag, text) || text.find_first_not_of(std::string(" \0", 2)) == std::string::npos) return {};
    std::vector<double> values;
    std::stringstream in(text);
    for (std::string part; std::getline(in, part, '\\');) {
        char* end = nullptr;
        const double v = std::strtod(part.c_str(), &end);
        while (end && *end == ' ') ++end;
        if (part.empty() || !end || *end != '\0' || !std::isfinite(v) || std::fabs(v) > double(limits::kMaxCoordinate))
            throw file_error(file, name, "'" + one_line(text) + "' is not " + std::to_string(count) + " finite numbers within ±1e18");
        values.push_back(v);
    }
    if (values.size() != count)
        throw file_error(file, name, "'" + one_line(text) + "' is not " + std::to_string(count) + " numbers");
    return values;
}

DicomGeometry dicom_geometry(const itk::MetaDataDictionary& dict, const std::string& file) {
    DicomGeometry g;
    g.position = dicom_numbers(dict, "0020|0032", "ImagePositionPatient", 3, file);
    g.orientation = dicom_numbers(dict, "0020|0037", "ImageOrientationPatient", 6, file);
    g.spacing = dicom_numbers(dict, "0028|0030", "PixelSpacing", 2, file);
    if (!g.orientation.empty()) {  // two unit vectors at a right angle
        const double* r = g.orientation.data();
        const double* c = r + 3;
        const double rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2], cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        const double rc = r[0] * c[0] + r[1] * c[1] + r[2] * c[2];
        if (!(std::fabs(rr - 1) <= 1e-3 && std::fabs(cc - 1) <= 1e-3 && std::fabs(rc) <= 1e-3))
            throw file_error(file, "ImageOrientationPatient", "the row and column directions are not orthonormal");
    }
    for (double v : g.spacing)
        if (!(v >= double(limits::kMinLength)))
            throw file_error(file, "PixelSpacing", "must be > 0, got " + std::to_string(v));
    return g;
}

// Every slice of a series read as headers only and checked before ITK computes with them (a
// position of 1e300 aborted in vnl; zero orientations and spacings became made-up geometry):
// each slice's own fields (dicom_geometry), then the positions along the slice normal distinct.
void check_series_geometry(const std::string& dir, const std::vector<std::string>& files) {
    std::vector<double> along;
    for (const std::string& file : files) {
        auto io = itk::GDCMImageIO::New();
        io->SetFileName(file);
        io->ReadImageInformation();
        const DicomGeometry g = dicom_geometry(io->GetMetaDataDictionary(), file);
        if (g.position.empty() || g.orientation.empty()) {
            if (files.size() > 1) throw file_error(file, "ImagePositionPatient", "missing: a series needs each slice's position and orientation");
            continue;
        }
        const double* r = g.orientation.data();
        const double* c = r + 3;
        const double n[3] = {r[1] * c[2] - r[2] * c[1], r[2] * c[0] - r[0] * c[2], r[0] * c[1] - r[1] * c[0]};
        along.push_back(g.position[0] * n[0] + g.position[1] * n[1] + g.position[2] * n[2]);
    }
    if (along.size() < 2) return;
    std::sort(along.begin(), along.end());
    const double span = along.back() - along.front();
    if (!(span > 0)) throw file_error(dir, "slices", "all " + std::to_string(along.size()) + " slices lie at one position");
    for (std::size_t i = 1; i < along.size(); ++i)
        if (!(along[i] - along[i - 1] > 1e-6 * span))
            throw file_error(dir, "slices", "two slices lie at one position (" + std::to_string(along[i]) + " along the normal): a duplicate?");
}

// The file names of the one series in `dir`, sorted by slice position along the slice normal.
std::vector<std::string> series_files(const std::string& dir) {
    auto names = itk::GDCMSeriesFileNames::New();
    names->SetUseSeriesDetails(true);  // one orientation, one size, one acquisition per series
    names->SetDirectory(dir);
    const std::vector<std::string>& uids = names->GetSeriesUIDs();
    if (uids.empty()) throw file_error(dir, "", "no DICOM series in this folder");
    if (uids.size() > 1) {
        std::string list;
        for (const std::string& uid : uids)
            list += (list.empty() ? "" : ", ") + std::to_string(names->GetFileNames(uid).size()) + " files";
        throw file_error(dir, "", "holds " + std::to_string(uids.size()) + " DICOM series (" + list +
                                      "); put each series in a folder of its own");
    }
    return names->GetFileNames(uids.front());
}

// Places `volume` (dims set) as ITK's geometry says: direction(r, a) is row r of index axis a's
// direction, in LPS for the patient-frame formats.
template <typename Direction, typename Spacing, typename Origin>
void place(Volume& volume, const std::string& path, ItkFormat format, const Direction& direction,
           const Spacing& spacing, const Origin& origin_lps) {
    std::array<std::array<double, 3>, 3> axes{};
    std::array<double, 3> origin{};
    const bool patient_frame = format != ItkFormat::tiff;
    for (int r = 0; r < 3; ++r) {
        const double sign = patient_frame && r < 2 ? -1.0 : 1.0;  // LPS → RAS
        for (int a = 0; a < 3; ++a)
            axes[std::size_t(a)][std::size_t(r)] = sign * (patient_frame ? direction(r, a) : (r == a ? 1.0 : 0.0)) * spacing(a);
        origin[std::size_t(r)] = patient_frame ? sign * origin_lps(r) : 0.0;
    }
    set_geometry(volume, path, "spacing", axes, origin);
    if (!patient_frame) {  // centred, axes as stored
        volume.placement[3] = volume.placement[7] = volume.placement[11] = 0.f;
    }
}

Volume to_volume(const std::string& path, const Image& image, ItkFormat format) {
    Volume volume;
    const Image::SizeType size = image.GetLargestPossibleRegion().GetSize();
    volume.dims = {int(size[0]), int(size[1]), int(size[2])};
    const std::size_t count = checked_voxel_count(path, {volume.dims[0], volume.dims[1], volume.dims[2]});
    volume.voxels.assign(image.GetBufferPointer(), image.GetBufferPointer() + count);  // x fastest, as ITK

    const Image::DirectionType& d = image.GetDirection();
    const Image::SpacingType& s = image.GetSpacing();
    const Image::PointType& o = image.GetOrigin();
    place(volume, path, format, [&](int r, int a) { return d[r][a]; }, [&](int a) { return s[a]; },
          [&](int r) { return o[r]; });
    return volume;
}

Volume read_series(const std::string& dir, const VolumeLoadOptions& options) {
    detail::StderrCapture capture;  // GDCM, libjpeg and OpenJPEG print to stderr: kept from the user
    std::uint64_t total_bytes = 0;
    folder_files(dir, &total_bytes);
    const std::vector<std::string> files = series_files(dir);
    check_series_geometry(dir, files);
    auto first = itk::GDCMImageIO::New();
    first->SetFileName(files.front());
    first->ReadImageInformation();
    check_header(dir, *first, files.size(), total_bytes, options);

    auto reader = itk::ImageSeriesReader<Image>::New();
    reader->SetImageIO(itk::GDCMImageIO::New());
    reader->SetFileNames(files);
    reader->Update();
    const Image& image = *reader->GetOutput();
    if (files.size() > 2) {
        double deviation = 0;
        const double spacing = image.GetSpacing()[2];
        if (itk::ExposeMetaData<double>(image.GetMetaDataDictionary(), "ITK_non_uniform_sampling_deviation", deviation) &&
            deviation > 0.1 * spacing)
            throw file_error(dir, "slices", "unevenly spaced: a gap deviates " + std::to_string(deviation) +
                                                " mm from the mean spacing " + std::to_string(spacing) +
                                                " mm (a missing slice?)");
    }
    return to_volume(dir, image, ItkFormat::dicom_series);
}

// The ImageIO of one file with its header read (no voxels) and checked: dims up to voxel_limit
// and options.max_voxels, against the bytes the voxels can come from.
itk::ImageIOBase::Pointer read_header(const std::string& path, ItkFormat format, std::uint64_t file_bytes,
                                      const VolumeLoadOptions& options, std::uint64_t voxel_limit) {
    // the bytes the voxels can come from: this file, or the data files a detached header names
    const std::uint64_t input_bytes = format == ItkFormat::nrrd || format == ItkFormat::metaimage
                                          ? check_detached_header(path, format == ItkFormat::nrrd)
                                          : file_bytes;
    itk::ImageIOBase::Pointer io = make_io(format);
    if (!io->CanReadFile(path.c_str()))
        throw file_error(path, "header", std::string("not a readable ") + format_name(format) + " file");
    io->SetFileName(path);
    io->ReadImageInformation();  // NRRD: teem reads the header and skips the data
    if (format == ItkFormat::dicom) dicom_geometry(io->GetMetaDataDictionary(), path);
    check_header(path, *io, 1, input_bytes, options, voxel_limit);
    return io;
}

Volume read_file(const std::string& path, ItkFormat format, const VolumeLoadOptions& options) {
    const std::uint64_t file_bytes = detail::regular_file_size(path);
    // MetaIO prints to std::cerr what it cannot parse (ITK's exception says it again), and reports a
    // short compressed stream only there, carrying on with a part-filled buffer: caught and made
    // the error. libtiff, libjpeg and OpenJPEG print to stderr: kept from the user too.
    detail::StderrCapture capture;
    if (format == ItkFormat::dicom) check_dicom_file(path);
    if (format == ItkFormat::tiff) check_tiff_pages(path, options.max_voxels);
    itk::ImageIOBase::Pointer io = read_header(path, format, file_bytes, options, limits::kMaxVolumeVoxels);

    auto reader = itk::ImageFileReader<Image>::New();
    reader->SetImageIO(io);
    reader->SetFileName(path);
    reader->Update();
    const std::string said = capture.text();
    if (said.find("not read completely") != std::string::npos)
        throw file_error(path, "data", "truncated: " + one_line(said));
    Volume volume = to_volume(path, *reader->GetOutput(), format);
    volume.stored_type = stored_type_name(*io);
    return volume;
}

}  // namespace

std::optional<ItkHeader> read_itk_header(const std::string& path, ItkFormat format, std::uint64_t voxel_limit) {
    quiet_once();
    try {
        detail::StderrCapture capture;
        VolumeLoadOptions options;
        options.max_voxels = voxel_limit;
        itk::ImageIOBase::Pointer io = read_header(path, format, detail::regular_file_size(path), options, voxel_limit);
        const std::optional<ScalarType> type = scalar_type(*io);
        if (!type) return std::nullopt;  // 64-bit integers: read whole
        ItkHeader header;
        header.type = *type;
        if (io->GetComponentSize() != type_size(header.type)) return std::nullopt;
        header.endian = io->GetByteOrder() == itk::IOByteOrderEnum::BigEndian ? Endian::big : Endian::little;
        Volume& volume = header.volume;
        const unsigned n = io->GetNumberOfDimensions();
        for (unsigned a = 0; a < 3; ++a) volume.dims[a] = a < n ? int(io->GetDimensions(a)) : 1;
        const auto axis = [&](unsigned a) { return a < n ? io->GetDirection(a) : std::vector<double>{}; };
        place(volume, path, format,
              [&](int r, int a) {
                  const std::vector<double> d = axis(unsigned(a));
                  return d.empty() ? (r == a ? 1.0 : 0.0) : (std::size_t(r) < d.size() ? d[std::size_t(r)] : 0.0);
              },
              [&](int a) { return unsigned(a) < n ? io->GetSpacing(unsigned(a)) : 1.0; },
              [&](int r) { return unsigned(r) < n ? io->GetOrigin(unsigned(r)) : 0.0; });
        volume.stored_type = stored_type_name(*io);
        volume.source = path;
        return header;
    } catch (const Error&) {
        throw;
    } catch (const itk::ExceptionObject& e) {
        throw file_error(path, "header", std::string("not a readable ") + format_name(format) + " file: " + one_line(e.GetDescription()));
    }
}

Volume read_itk(const std::string& path, ItkFormat format, const VolumeLoadOptions& options) {
    quiet_once();
    try {
        return format == ItkFormat::dicom_series ? read_series(path, options) : read_file(path, format, options);
    } catch (const Error&) {
        throw;
    } catch (const itk::ExceptionObject& e) {
        std::string what = one_line(e.GetDescription());
        // "ITK ERROR: NrrdImageIO(0x55…): Read: …": the class and its address say nothing to a user
        const std::size_t at = what.find("): ");
        if (what.rfind("ITK ERROR: ", 0) == 0 && at != std::string::npos) what.erase(0, at + 3);
        throw file_error(path, "", std::string("not a readable ") + format_name(format) +
                                       (format == ItkFormat::dicom_series ? " series: " : " file: ") + what);
    } catch (const std::exception& e) {  // std::bad_alloc, …
        throw file_error(path, "", std::string("cannot read the ") + format_name(format) + " data: " + one_line(e.what()));
    }
}

// ---- test-data writers ----
namespace {

template <typename Pixel>
typename itk::Image<Pixel, 3>::Pointer make_image(const std::array<int, 3>& dims, const ItkGeometry& g) {
    using ImageT = itk::Image<Pixel, 3>;
    auto image = ImageT::New();
    typename ImageT::RegionType region;
    region.SetSize({{itk::SizeValueType(dims[0]), itk::SizeValueType(dims[1]), itk::SizeValueType(dims[2])}});
    image->SetRegions(region);
    image->Allocate();
    typename ImageT::DirectionType direction;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) direction[r][c] = g.direction[std::size_t(r * 3 + c)];
    image->SetDirection(direction);
    image->SetSpacing(g.spacing.data());
    image->SetOrigin(g.origin.data());
    return image;
}

template <typename ImageT>
void write_image(const std::string& path, ImageT* image, itk::ImageIOBase* io, bool compress) {
    auto writer = itk::ImageFileWriter<ImageT>::New();
    writer->SetInput(image);
    writer->SetImageIO(io);
    writer->SetFileName(path);
    writer->SetUseCompression(compress);
    writer->Update();
}

// A UID under 2.25 (UUID-derived), unique per run and per series written.
std::string uid(unsigned long long series, const std::string& tail) {
    static const unsigned long long run = static_cast<unsigned long long>(
        std::chrono::steady_clock::now().time_since_epoch().count() & 0xffffffffffffULL);
    return "2.25." + std::to_string(run) + "." + std::to_string(series) + tail;
}

std::string join3(double a, double b, double c) {
    std::ostringstream s;
    s.precision(17);
    s << a << '\\' << b << '\\' << c;
    return s.str();
}

}  // namespace

void write_itk(const std::string& path, const std::array<int, 3>& dims, const std::vector<float>& values,
               const ItkGeometry& geometry, bool compress) {
    quiet_once();
    const std::string ext = fs::path(path).extension().string();
    try {
        if (ext == ".tif" || ext == ".tiff") {
            auto image = make_image<std::uint16_t>(dims, geometry);
            std::uint16_t* out = image->GetBufferPointer();
            for (std::size_t i = 0; i < values.size(); ++i) out[i] = std::uint16_t(std::lround(values[i]));
            write_image(path, image.GetPointer(), itk::TIFFImageIO::New().GetPointer(), compress);
            return;
        }
        auto image = make_image<float>(dims, geometry);
        std::copy(values.begin(), values.end(), image->GetBufferPointer());
        itk::ImageIOBase::Pointer io;
        if (ext == ".nrrd" || ext == ".nhdr") io = itk::NrrdImageIO::New().GetPointer();
        else io = itk::MetaImageIO::New().GetPointer();
        write_image(path, image.GetPointer(), io.GetPointer(), compress);
    } catch (const itk::ExceptionObject& e) {
        throw file_error(path, "", "cannot write: " + one_line(e.GetDescription()));
    }
}

void write_dicom_series(const std::string& folder, const std::array<int, 3>& dims,
                        const std::vector<std::int16_t>& stored, const ItkGeometry& g, double slope,
                        double intercept) {
    quiet_once();
    fs::create_directories(folder);
    static std::atomic<unsigned long long> count{0};
    const unsigned long long n = ++count;
    const std::string study = uid(n, ".1"), series = uid(n, ".2"), frame = uid(n, ".3");
    const std::size_t slice_size = std::size_t(dims[0]) * std::size_t(dims[1]);
    const auto& d = g.direction;  // row-major; column a = direction of index axis a
    std::ostringstream orientation;
    orientation.precision(17);
    orientation << d[0] << '\\' << d[3] << '\\' << d[6] << '\\' << d[1] << '\\' << d[4] << '\\' << d[7];
    std::ostringstream spacing;
    spacing.precision(17);
    spacing << g.spacing[1] << '\\' << g.spacing[0];  // PixelSpacing: between rows (y), between columns (x)
    for (int z = 0; z < dims[2]; ++z) {
        ItkGeometry slice = g;
        for (int r = 0; r < 3; ++r) slice.origin[std::size_t(r)] += d[std::size_t(r * 3 + 2)] * g.spacing[2] * z;
        auto image = make_image<std::int16_t>({dims[0], dims[1], 1}, slice);
        // GDCM's writer takes real values and stores (value − intercept) / slope: hand it those
        for (std::size_t i = 0; i < slice_size; ++i) {
            const double real = stored[slice_size * std::size_t(z) + i] * slope + intercept;
            if (!(real >= -32768 && real <= 32767))
                throw file_error(folder, "", "a real value " + std::to_string(real) + " does not fit int16");
            image->GetBufferPointer()[i] = std::int16_t(std::lround(real));
        }
        itk::MetaDataDictionary& dict = image->GetMetaDataDictionary();
        const auto put = [&](const char* tag, const std::string& value) { itk::EncapsulateMetaData<std::string>(dict, tag, value); };
        put("0008|0016", "1.2.840.10008.5.1.4.1.1.2");  // CT Image Storage
        put("0008|0018", uid(n, ".4." + std::to_string(z + 1)));
        put("0002|0003", uid(n, ".4." + std::to_string(z + 1)));
        put("0008|0060", "CT");
        put("0028|0004", "MONOCHROME2");
        put("0008|0008", "ORIGINAL\\PRIMARY\\AXIAL");
        put("0010|0010", "SOMBRA^TEST");
        put("0020|000d", study);
        put("0020|000e", series);
        put("0020|0052", frame);
        put("0020|0011", "1");
        put("0020|0013", std::to_string(z + 1));
        put("0020|0032", join3(slice.origin[0], slice.origin[1], slice.origin[2]));
        put("0020|0037", orientation.str());
        put("0028|0030", spacing.str());
        put("0018|0050", std::to_string(g.spacing[2]));
        put("0028|1052", std::to_string(intercept));
        put("0028|1053", std::to_string(slope));
        auto io = itk::GDCMImageIO::New();
        io->KeepOriginalUIDOn();
        char name[32];
        std::snprintf(name, sizeof name, "slice%04d.dcm", (z * 7919) % 10000);  // names in no position order
        try {
            write_image((fs::path(folder) / name).string(), image.GetPointer(), io.GetPointer(), false);
        } catch (const itk::ExceptionObject& e) {
            throw file_error(folder, "", "cannot write a DICOM slice: " + one_line(e.GetDescription()));
        }
    }
}

}  // namespace sombra::volume_io
