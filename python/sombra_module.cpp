// sombra — Python bindings (pybind11): `import sombra` (docs/python.md). Thin: numpy arrays in and
// out, option values as strings through the library's own parsers (render.h set_render_option,
// scene.h parse_light_type).
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>

#include "sombra/sombra.h"

namespace py = pybind11;
using namespace sombra;

namespace {

using FloatArray = py::array_t<float, py::array::c_style>;
using DoubleArray = py::array_t<double, py::array::c_style>;

std::string shape_of(const py::array& a) {
    std::ostringstream s;
    s << "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) s << (d ? ", " : "") << a.shape(d);
    s << (a.ndim() == 1 ? ",)" : ")");
    return s.str();
}

// `value` as a C-ordered array of `ndim` dimensions of T, the sizes in `sizes` (−1: any); otherwise
// a ValueError naming the function and the argument. Arrays of the dtype kinds in `kinds` (numpy's
// 'f', 'i', 'u') and Python sequences convert to T.
// An array's shape and element count are checked before anything is copied: a zero-stride view
// (np.broadcast_to) of 2⁴⁰ elements costs no memory until converted. At most `max_elements`.
// The dtype kind, shape and size of a numpy array checked as checked_array does, before any copy.
void check_array_layout(const py::array& array, const char* where, const char* name, const std::vector<py::ssize_t>& sizes,
                        const char* expected, std::uint64_t max_elements, const std::string& kinds) {
    auto fail = [&](const std::string& got) {
        throw py::value_error(std::string(where) + ": " + name + ": expected " + expected + ", got " + got);
    };
    if (kinds.find(array.dtype().kind()) == std::string::npos) fail("dtype " + std::string(py::str(array.dtype())));
    bool shaped = array.ndim() == py::ssize_t(sizes.size());
    for (std::size_t d = 0; shaped && d < sizes.size(); ++d) shaped = sizes[d] < 0 || array.shape(py::ssize_t(d)) == sizes[d];
    if (!shaped) fail("shape " + shape_of(array));
    if (std::uint64_t(array.size()) > max_elements)
        fail(std::to_string(array.size()) + " elements " + shape_of(array) + ", more than the limit of " + std::to_string(max_elements));
}

template <typename T>
py::array_t<T, py::array::c_style> checked_array(const py::handle& value, const char* where, const char* name,
                                                   std::vector<py::ssize_t> sizes, const char* expected,
                                                   std::uint64_t max_elements = limits::kMaxVolumeVoxels,
                                                   const std::string& kinds = "fiu") {
    auto fail = [&](const std::string& got) {
        throw py::value_error(std::string(where) + ": " + name + ": expected " + expected + ", got " + got);
    };
    if (py::isinstance<py::array>(value))
        check_array_layout(py::reinterpret_borrow<py::array>(value), where, name, sizes, expected, max_elements, kinds);
    py::array_t<T, py::array::c_style> typed;
    try {
        typed = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(value);
    } catch (const py::error_already_set&) {
    }
    if (!typed) fail("a " + std::string(py::str(value.get_type().attr("__name__"))) + " that is not a numeric array");
    bool ok = typed.ndim() == py::ssize_t(sizes.size());
    for (std::size_t d = 0; ok && d < sizes.size(); ++d) ok = sizes[d] < 0 || typed.shape(py::ssize_t(d)) == sizes[d];
    if (!ok) fail("shape " + shape_of(typed));
    const T* data = typed.data();
    for (py::ssize_t i = 0; i < typed.size(); ++i)
        if (!std::isfinite(double(data[i]))) fail("a non-finite value at flat index " + std::to_string(i));
    return typed;
}

Vec3 vec3(const py::handle& value, const char* where, const char* name) {
    auto a = checked_array<float>(value, where, name, {3}, "3 numbers");
    return {a.at(0), a.at(1), a.at(2)};
}

std::array<float, 16> matrix4(const py::handle& value, const char* where, const char* name) {
    auto a = checked_array<float>(value, where, name, {4, 4}, "a 4×4 matrix");
    std::array<float, 16> m{};
    std::copy_n(a.data(), 16, m.begin());
    return m;
}

py::array_t<float> matrix_array(const std::array<float, 16>& m) {
    py::array_t<float> a({4, 4});
    std::copy(m.begin(), m.end(), a.mutable_data());
    return a;
}

py::tuple tuple3(const Vec3& v) { return py::make_tuple(v[0], v[1], v[2]); }

// A Python value as an option value of the declared kind: bool, an integer (anything with
// __index__, numpy's too), a real number, or a str; anything else is refused naming the argument.
OptionValue option_value_of(const OptionSpec& spec, const py::handle& value, const std::string& label) {
    const bool is_bool = py::isinstance<py::bool_>(value);
    const bool is_integer = !is_bool && py::hasattr(value, "__index__");
    const bool is_number = !is_bool && !py::isinstance<py::str>(value) && py::hasattr(value, "__float__");
    switch (spec.kind) {
        case OptionKind::Flag:
            if (is_bool) return OptionValue(value.cast<bool>());
            break;
        case OptionKind::Choice:
            if (py::isinstance<py::str>(value)) return OptionValue(value.cast<std::string>());
            break;
        case OptionKind::Integer:
            if (is_integer) {
                long long v = PyLong_AsLongLong(py::int_(py::reinterpret_borrow<py::object>(value)).ptr());
                if (v == -1 && PyErr_Occurred()) {  // beyond 64 bits: out of every range
                    PyErr_Clear();
                    throw Error(label + ": must lie in " + option_range_text(spec) + ", got " + std::string(py::str(value)));
                }
                return OptionValue(v);
            }
            break;
        case OptionKind::Real:
            if (is_number) return OptionValue(value.cast<double>());
            break;
    }
    static const char* expected[] = {"int", "float", "bool", "str"};
    throw Error(label + ": expected " + expected[int(spec.kind)] + ", got " + std::string(py::str(value.get_type().attr("__name__"))));
}

py::object python_value(const OptionValue& value) {
    return std::visit([](const auto& v) { return py::object(py::cast(v)); }, value);
}

const OptionSpec& option_spec(const std::string& name, const std::string& where) {
    const OptionSpec* spec = find_render_option(name);
    if (!spec || spec->key != name) throw py::value_error(where + ": unknown option '" + name + "' (see sombra.RenderOptions)");
    return *spec;
}

// Keywords onto options, each checked by its declaration and named as the caller wrote it.
void apply_keywords(RenderOptions& options, const py::kwargs& kwargs, const std::string& where) {
    for (const auto& [key, value] : kwargs) {
        const std::string name = py::str(key);
        const OptionSpec& spec = option_spec(name, where);
        const std::string label = where.empty() ? name : where + ": " + name;
        try {
            set_option(options, spec, option_value_of(spec, value, label), label);
        } catch (const Error& e) {
            throw py::value_error(e.what());
        }
    }
}

// A call's options: the given RenderOptions, else the scene file's "render" block; then the
// keywords. An option given as a keyword that does not apply to the technique is refused.
RenderOptions call_options(const Scene& scene, const py::object& options, const py::kwargs& kwargs, const char* where) {
    if (!options.is_none() && !py::isinstance<RenderOptions>(options))
        throw py::value_error(std::string(where) + ": options: expected a sombra.RenderOptions");
    RenderOptions o = options.is_none() ? scene_render_options(scene) : options.cast<RenderOptions>();
    apply_keywords(o, kwargs, where);
    return o;
}

void check_keywords_apply(const RenderOptions& o, const py::kwargs& kwargs, const char* where) {
    for (const auto& item : kwargs) {
        const std::string name = py::str(item.first);
        try {
            check_option_applies(option_spec(name, where), o.shadows, std::string(where) + ": " + name, "shadows=");
        } catch (const Error& e) {
            throw py::value_error(e.what());
        }
    }
}

py::dict stats_dict(const RenderStats& stats) { return py::module_::import("json").attr("loads")(stats.to_json()); }

std::vector<Vec3> points_of(const py::handle& points, const char* where) {
    auto a = checked_array<double>(points, where, "points", {-1, 3}, "an (N, 3) array of world points", limits::kMaxPoints * 3);
    std::vector<Vec3> result(std::size_t(a.shape(0)));
    for (std::size_t i = 0; i < result.size(); ++i)
        for (std::size_t k = 0; k < 3; ++k) result[i][k] = float(a.data()[i * 3 + k]);
    return result;
}

// Transfer function points as an (N, columns) array: x first, sorted, at least one row.
template <typename Point>
std::vector<Point> tf_points(const py::handle& value, const char* name, py::ssize_t columns, const char* expected) {
    auto a = checked_array<float>(value, "Scene.add_volume", name, {-1, columns}, expected);
    if (a.shape(0) < 1) throw py::value_error(std::string("Scene.add_volume: ") + name + ": needs at least one point");
    std::vector<Point> points(std::size_t(a.shape(0)));
    for (std::size_t i = 0; i < points.size(); ++i) {
        std::memcpy(&points[i], a.data() + i * std::size_t(columns), sizeof(Point));
        if (i && !(points[i].x > points[i - 1].x))
            throw py::value_error(std::string("Scene.add_volume: ") + name + ": x must increase (row " + std::to_string(i) + ")");
    }
    return points;
}

}  // namespace

PYBIND11_MODULE(sombra, m) {
    m.doc() = "sombra: volumetric shadows (deep shadow maps, shadow rays, low-pass SAT shadows) on OpenCL";
    py::register_exception<Error>(m, "Error", PyExc_RuntimeError).attr("__doc__") =
        "sombra's own errors (a RuntimeError): one line naming the file and field, or the option, that is wrong; "
        "bad arguments raise ValueError or TypeError naming the function and argument instead.";

    py::class_<Context>(m, "Context", "An OpenCL device with its compiled kernels and kept scene data.")
        .def(py::init<const std::string&>(), py::arg("device") = "auto",
             "device: 'auto', 'cpu', 'gpu' or an index of list_devices()")
        .def_property_readonly("device", [](const Context& c) { return c.device().name; })
        .def("release_prepared_scenes", &Context::release_prepared_scenes);
    m.def("forget_shadow_cache_choices", &forget_shadow_cache_choices,
          "The shadow cache's auto remembers its choice per frame (scene, camera, size, options, device) for the "
          "process, so that the same frame renders the same image; this forgets them: the next frames measure.");
    m.def("list_devices", [] {
        py::list devices;
        for (const DeviceInfo& d : list_devices())
            devices.append(py::dict(py::arg("index") = d.index, py::arg("name") = d.name, py::arg("platform") = d.platform,
                                    py::arg("is_gpu") = d.is_gpu));
        return devices;
    },
          "The OpenCL devices, as `sombra devices` lists them: dicts of index, name, platform, is_gpu; Context(str(index)) "
          "chooses one.");

    py::class_<RenderOptions> options(m, "RenderOptions",
                                      "The render options (sombra/options.h): each an attribute and a keyword of RenderOptions(), "
                                      "render(), shadow_transmittance() and build_deep_shadow_maps(), checked when set.");
    options.def(py::init([](const py::kwargs& kwargs) {
                    RenderOptions o;
                    apply_keywords(o, kwargs, "RenderOptions");
                    return o;
                }))
        .def("copy", [](const RenderOptions& o) { return RenderOptions(o); });
    for (const OptionSpec& spec : render_option_specs()) {
        const std::string doc = spec.help + (option_range_text(spec).empty() ? "" : " " + option_range_text(spec)) +
                                "; default " + option_value_text(spec.default_value());
        options.def_property(
            spec.key.c_str(), [&spec](const RenderOptions& o) { return python_value(spec.get(o)); },
            [&spec](RenderOptions& o, const py::object& value) {
                try {
                    set_option(o, spec, option_value_of(spec, value, spec.key), spec.key);
                } catch (const Error& e) {
                    throw py::value_error(e.what());
                }
            },
            doc.c_str());
    }
    m.def(
        "render_option_declarations",
        [] {
            py::list list;
            static const char* kinds[] = {"int", "float", "bool", "str"};
            for (const OptionSpec& spec : render_option_specs()) {
                py::list techniques;
                for (ShadowTechnique t : spec.techniques) techniques.append(shadow_technique_name(t));
                list.append(py::dict(py::arg("key") = spec.key, py::arg("flag") = spec.flag, py::arg("type") = kinds[int(spec.kind)],
                                     py::arg("default") = python_value(spec.default_value()),
                                     py::arg("range") = option_range_text(spec), py::arg("choices") = spec.choices,
                                     py::arg("help") = spec.help, py::arg("unit") = spec.unit, py::arg("techniques") = techniques,
                                     py::arg("keys_data") = spec.keys_data));
            }
            return list;
        },
        "Every render option's declaration (sombra/options.h): key, flag, type, default, range, choices, help, unit, the "
        "techniques it applies to (empty: all) and whether changing it rebuilds prepared data.");
    options.def("__repr__", [](const RenderOptions& o) {
        std::string text = "sombra.RenderOptions(";
        for (const OptionSpec& spec : render_option_specs())
            text += (text.back() == '(' ? "" : ", ") + spec.key + "=" + std::string(py::repr(python_value(spec.get(o))));
        return text + ")";
    });

    py::class_<Scene>(m, "Scene", "A scene: volumes (numpy arrays), lights, camera, background.")
        .def(py::init([](int width, int height) {
                 Scene s;
                 s.width = width, s.height = height;
                 return s;
             }),
             py::arg("width") = 512, py::arg("height") = 512)
        .def_readwrite("width", &Scene::width)
        .def_readwrite("height", &Scene::height)
        .def_readwrite("ambient_intensity", &Scene::ambient_intensity)
        .def_property(
            "background", [](const Scene& s) { return tuple3(s.background); },
            [](Scene& s, const py::object& v) { s.background = vec3(v, "Scene.background", "background"); })
        .def_property_readonly("volume_count", [](const Scene& s) { return s.volumes.size(); })
        .def_property_readonly("light_count", [](const Scene& s) { return s.lights.size(); })
        .def_property_readonly("source", [](const Scene& s) { return s.source; })
        .def(
            "bounds",
            [](const Scene& s) {
                const Box3 b = world_bounds(s);
                if (b.empty()) throw py::value_error("Scene.bounds: the scene has no volume or mesh");
                return py::make_tuple(tuple3(b.lo), tuple3(b.hi));
            },
            "World bounds ((x, y, z) low, (x, y, z) high) of every volume's voxel cells and mesh, as `sombra info` reports "
            "them and as a camera-less scene is framed.")
        .def(
            "volume_bounds",
            [](const Scene& s, std::size_t i) {
                if (i >= s.volumes.size()) throw py::index_error("Scene.volume_bounds: index: no volume " + std::to_string(i));
                const Box3 b = world_bounds(s.volumes[i]);
                return py::make_tuple(tuple3(b.lo), tuple3(b.hi));
            },
            py::arg("index"), "World bounds of volume `index` (its box ± half a voxel, through its transform).")
        .def(
            "value_range",
            [](const Scene& s, std::size_t i) {
                if (i >= s.volumes.size()) throw py::index_error("Scene.value_range: index: no volume " + std::to_string(i));
                return py::make_tuple(s.volumes[i].volume->value_min, s.volumes[i].volume->value_max);
            },
            py::arg("index"), "(min, max) of volume `index`'s values, as read (the units its transfer function uses).")
        .def("render_options", &scene_render_options,
             "The scene file's \"render\" block as RenderOptions (the defaults where it is silent); what render() uses when "
             "no options are given.")
        .def(
            "set_camera",
            [](Scene& s, const py::object& position, const py::object& look_at, const py::object& up, float fov_y_deg) {
                Camera camera = s.camera;  // checked whole before it replaces the scene's
                camera.position = vec3(position, "Scene.set_camera", "position");
                camera.look_at = vec3(look_at, "Scene.set_camera", "look_at");
                camera.up = vec3(up, "Scene.set_camera", "up");
                camera.fov_y_deg = fov_y_deg;
                if (auto problem = camera_problem(camera)) throw py::value_error("Scene.set_camera: " + problem->field + ": " + problem->what);
                s.camera = camera;
            },
            py::arg("position"), py::arg("look_at"), py::arg("up") = py::make_tuple(0, 1, 0), py::arg("fov_y_deg") = 40.f)
        .def(
            "add_volume",
            [](Scene& s, const py::object& voxels, const py::object& spacing, const py::object& transform,
               const py::object& opacity, const py::object& color, float step_voxels, float opacity_unit, const std::string& name) {
                // any real dtype and memory order (uint8 and int16 CT, float64, Fortran order, views), as
                // float32 in C order: the values as they are (no rescaling, as the CLI reads .npy). One
                // copy at most: a float32 C-ordered array is copied into the volume; any other array is
                // converted by numpy straight into the volume's memory (no float32 temporary)
                const char* expected = "a real array of shape (z, y, x)";
                auto volume = std::make_shared<Volume>();
                if (py::isinstance<py::array>(voxels) && !py::isinstance<py::array_t<float, py::array::c_style>>(voxels)) {
                    const auto array = py::reinterpret_borrow<py::array>(voxels);
                    check_array_layout(array, "Scene.add_volume", "voxels", {-1, -1, -1}, expected, limits::kMaxVolumeVoxels, "fiu");
                    if (array.size() == 0) throw py::value_error("Scene.add_volume: voxels: empty array " + shape_of(array));
                    volume->dims = {int(array.shape(2)), int(array.shape(1)), int(array.shape(0))};
                    volume->voxels.resize(std::size_t(array.size()));
                    py::array_t<float> into({array.shape(0), array.shape(1), array.shape(2)}, volume->voxels.data(),
                                            py::capsule(volume->voxels.data(), [](void*) {}));  // a view: the volume owns it
                    py::module_::import("numpy").attr("copyto")(into, array, py::arg("casting") = "unsafe");
                    for (std::size_t i = 0; i < volume->voxels.size(); ++i)
                        if (!std::isfinite(volume->voxels[i]))
                            throw py::value_error(std::string("Scene.add_volume: voxels: expected ") + expected +
                                                  ", got a non-finite value at flat index " + std::to_string(i));
                } else {
                    auto a = checked_array<float>(voxels, "Scene.add_volume", "voxels", {-1, -1, -1}, expected);
                    if (a.size() == 0) throw py::value_error("Scene.add_volume: voxels: empty array " + shape_of(a));
                    volume->dims = {int(a.shape(2)), int(a.shape(1)), int(a.shape(0))};  // x fastest: C order (z, y, x)
                    volume->voxels.assign(a.data(), a.data() + a.size());
                }
                volume->spacing = vec3(spacing, "Scene.add_volume", "spacing");
                volume->source = name.empty() ? "numpy array" : name;
                volume->update_range();
                VolumeInstance vi;
                vi.volume = volume;
                vi.spacing = volume->spacing;
                if (!transform.is_none()) vi.transform = matrix4(transform, "Scene.add_volume", "transform");
                vi.transfer_function.opacity_points =
                    tf_points<TransferFunction::OpacityPoint>(opacity, "opacity", 2, "(N, 2) rows of (value, alpha)");
                vi.transfer_function.color_points =
                    tf_points<TransferFunction::ColorPoint>(color, "color", 4, "(N, 4) rows of (value, r, g, b)");
                vi.step_voxels = step_voxels;
                vi.opacity_unit = opacity_unit;
                vi.name = name;
                if (auto problem = volume_problem(vi)) throw py::value_error("Scene.add_volume: " + problem->field + ": " + problem->what);
                s.volumes.push_back(vi);
                return s.volumes.size() - 1;
            },
            py::arg("voxels"), py::arg("spacing") = py::make_tuple(1, 1, 1), py::arg("transform") = py::none(),
            py::arg("opacity") = std::vector<std::array<float, 2>>{{0.f, 0.f}, {1.f, 1.f}},
            py::arg("color") = std::vector<std::array<float, 4>>{{0.f, 1.f, 1.f, 1.f}}, py::arg("step_voxels") = 0.5f,
            py::arg("opacity_unit") = 0.f, py::arg("name") = "",
            "voxels: float32 (z, y, x) in C order, voxel (x, y, z) at ((x − (nx−1)/2)·spacing, …) of the object "
            "frame, then `transform` (4×4, row-major, column vectors). Returns the volume's index.")
        .def(
            "add_mesh",
            [](Scene& s, const py::object& vertices, const py::object& triangles, const py::object& color, float opacity,
               const py::object& transform, const std::string& name) {
                if (s.meshes.size() >= std::size_t(limits::kMaxMeshes))
                    throw py::value_error("Scene.add_mesh: at most " + std::to_string(limits::kMaxMeshes) + " meshes per scene");
                auto v = checked_array<float>(vertices, "Scene.add_mesh", "vertices", {-1, 3}, "an (N, 3) array of positions",
                                              limits::kMaxMeshVertices * 3);
                auto t = checked_array<std::int64_t>(triangles, "Scene.add_mesh", "triangles", {-1, 3}, "integer vertex indices",
                                                     limits::kMaxMeshTriangles * 3, "iu");
                auto mesh = std::make_shared<Mesh>();
                mesh->source = name.empty() ? "numpy mesh" : name;
                for (py::ssize_t i = 0; i < v.shape(0); ++i) mesh->positions.push_back({v.at(i, 0), v.at(i, 1), v.at(i, 2)});
                for (py::ssize_t i = 0; i < t.shape(0); ++i) {
                    std::array<std::uint32_t, 3> tri{};
                    for (int k = 0; k < 3; ++k) {
                        const std::int64_t index = t.at(i, k);
                        if (index < 0 || index >= v.shape(0))
                            throw py::value_error("Scene.add_mesh: triangles: index " + std::to_string(index) + " in row " +
                                                  std::to_string(i) + " is not a vertex (0 … " + std::to_string(v.shape(0) - 1) + ")");
                        tri[std::size_t(k)] = std::uint32_t(index);
                    }
                    mesh->triangles.push_back(tri);
                }
                if (mesh->triangles.empty()) throw py::value_error("Scene.add_mesh: triangles: needs at least one triangle");
                MeshInstance mi;
                mi.mesh = mesh;
                mi.material.color = vec3(color, "Scene.add_mesh", "color");
                if (!(opacity >= 0.f && opacity <= 1.f))
                    throw py::value_error("Scene.add_mesh: opacity: must lie in [0, 1], got " + std::to_string(opacity));
                mi.material.opacity = opacity;
                if (!transform.is_none()) mi.transform = matrix4(transform, "Scene.add_mesh", "transform");
                mi.name = mesh->source;
                s.meshes.push_back(mi);
                return s.meshes.size() - 1;
            },
            py::arg("vertices"), py::arg("triangles"), py::arg("color") = py::make_tuple(0.8, 0.8, 0.8), py::arg("opacity") = 1.f,
            py::arg("transform") = py::none(), py::arg("name") = "",
            "A translucent triangle mesh (meshes.md): vertices (N, 3) in object space, triangles (M, 3) indices, its color "
            "and the opacity of one surface crossing, object → world transform (4×4, default identity); returns its index.")
        .def(
            "add_light",
            [](Scene& s, const std::string& type, const py::object& position, const py::object& direction,
               const py::object& color, float intensity, float cone_angle_deg) {
                Light l;
                try {
                    l.type = parse_light_type(type);
                } catch (const Error& e) {
                    throw py::value_error(std::string("Scene.add_light: type: ") + e.what());
                }
                l.position = vec3(position, "Scene.add_light", "position");
                l.direction = vec3(direction, "Scene.add_light", "direction");
                l.color = vec3(color, "Scene.add_light", "color");
                l.intensity = intensity;
                l.cone_angle_deg = cone_angle_deg;
                // the rules scene files obey (sombra/scene.h), at the call that received the value
                if (auto problem = light_problem(l)) throw py::value_error("Scene.add_light: " + problem->field + ": " + problem->what);
                normalize_light_direction(l);
                s.lights.push_back(l);
                return s.lights.size() - 1;
            },
            py::arg("type"), py::arg("position") = py::make_tuple(0, 0, 0), py::arg("direction") = py::make_tuple(0, 0, -1),
            py::arg("color") = py::make_tuple(1, 1, 1), py::arg("intensity") = 1.f, py::arg("cone_angle_deg") = 30.f,
            "type: 'directional', 'spot' or 'point'. Returns the light's index.")
        .def("__repr__", [](const Scene& s) {
            return "sombra.Scene(" + std::to_string(s.volumes.size()) + " volumes, " + std::to_string(s.lights.size()) +
                   " lights, " + std::to_string(s.width) + "x" + std::to_string(s.height) + ")";
        });

    m.def(
        "load_scene",
        [](const std::string& path, const std::string& non_finite) {
            VolumeLoadOptions load;
            if (non_finite != "reject" && non_finite != "sanitize")
                throw py::value_error("load_scene: non_finite: expected 'reject' or 'sanitize', got '" + non_finite + "'");
            load.non_finite = non_finite == "sanitize" ? NonFinitePolicy::Sanitize : NonFinitePolicy::Reject;
            return load_scene(path, load);
        },
        py::arg("path"), py::arg("non_finite") = "reject", "A scene file (JSON), as `sombra render` reads it.");

    m.def(
        "volume_info",
        [](const std::string& path, const std::string& grid) { return py::module_::import("json").attr("loads")(volume_info_json(path, grid)); },
        py::arg("path"), py::arg("grid") = "",
        "What `sombra info --json FILE` prints for a volume file, as a dict: format, voxel_type, dims, spacing, world_bounds, "
        "placement, min, max, mean, percentiles, background, foreground_percentiles, histogram, non_finite, preset.");

    m.def(
        "render",
        [](Context& context, const Scene& scene, const py::object& options, const py::kwargs& kwargs) {
            RenderOptions o = call_options(scene, options, kwargs, "render");
            check_keywords_apply(o, kwargs, "render");
            RenderResult result;
            {
                py::gil_scoped_release release;
                result = render(context, scene, o);
            }
            py::array_t<float> image({py::ssize_t(result.image.height), py::ssize_t(result.image.width), py::ssize_t(4)});
            std::copy(result.image.rgba.begin(), result.image.rgba.end(), image.mutable_data());
            return py::module_::import("sombra").attr("Rendered")(image, stats_dict(result.stats));
        },
        py::arg("context"), py::arg("scene"), py::arg("options") = py::none(),
        "Returns a Rendered (image, stats): float32 (height, width, 4) linear RGBA, top row first, background composited; "
        "the stats as `sombra render --stats` writes them. Options: a RenderOptions (default: the scene file's \"render\" "
        "block) and/or its attributes as keywords; a keyword that does not apply to the technique is refused.");

    m.def(
        "shadow_transmittance",
        [](Context& context, const Scene& scene, int light, const py::object& points, const py::object& options,
           const py::kwargs& kwargs) {
            RenderOptions o = call_options(scene, options, kwargs, "shadow_transmittance");
            // a query about shadows: deep shadow maps unless a technique is named (a scene's "render"
            // block may say none, which has no shadow term to query)
            if (options.is_none() && !kwargs.contains("shadows") && o.shadows == ShadowTechnique::None) o.shadows = ShadowTechnique::Dsm;
            check_keywords_apply(o, kwargs, "shadow_transmittance");
            std::vector<Vec3> p = points_of(points, "shadow_transmittance");
            ShadowQuery query;
            {
                py::gil_scoped_release release;
                query = shadow_transmittance(context, scene, light, p, o);
            }
            return py::make_tuple(py::array_t<double>(py::ssize_t(query.transmittance.size()), query.transmittance.data()),
                                  stats_dict(query.stats));
        },
        py::arg("context"), py::arg("scene"), py::arg("light"), py::arg("points"), py::arg("options") = py::none(),
        "Transmittance to light `light` at (N, 3) world points by options.shadows (default 'dsm' when neither options nor "
        "shadows= is given; 'rays', 'shadowmap', 'lowpass', …); returns (T, stats).");

    m.def(
        "reference_transmittance",
        [](const Scene& scene, int light, const py::object& points, double step_voxels) {
            std::vector<Vec3> p = points_of(points, "reference_transmittance");
            py::array_t<double> result(py::ssize_t(p.size()));
            double* out = result.mutable_data();
            {
                py::gil_scoped_release release;
                for (std::size_t i = 0; i < p.size(); ++i) out[i] = reference_transmittance(scene, light, p[i], step_voxels);
            }
            return result;
        },
        py::arg("scene"), py::arg("light"), py::arg("points"), py::arg("step_voxels") = 0.05,
        "Brute-force ground truth (double precision) at (N, 3) world points.");

    py::class_<DeepShadowMap>(m, "DeepShadowMap", "One view of a light's deep shadow map (shadows.h).")
        .def_readonly("width", &DeepShadowMap::width)
        .def_readonly("height", &DeepShadowMap::height)
        .def_readonly("light_name", &DeepShadowMap::light_name)
        .def_property_readonly("first", [](const DeepShadowMap& d) { return py::array_t<std::uint32_t>(py::ssize_t(d.first.size()), d.first.data()); },
                               "width·height + 1 offsets: texel (x, y) owns nodes first[y·width + x] … first[… + 1]")
        .def_property_readonly("depth", [](const DeepShadowMap& d) {
            py::array_t<float> a(py::ssize_t(d.nodes.size()));
            for (std::size_t i = 0; i < d.nodes.size(); ++i) a.mutable_data()[i] = d.nodes[i].depth;
            return a;
        })
        .def_property_readonly("opacity", [](const DeepShadowMap& d) {
            py::array_t<float> a(py::ssize_t(d.nodes.size()));
            for (std::size_t i = 0; i < d.nodes.size(); ++i) a.mutable_data()[i] = d.nodes[i].opacity;
            return a;
        })
        .def_property_readonly("world_to_camera", [](const DeepShadowMap& d) { return matrix_array(d.world_to_camera); })
        .def_property_readonly("world_to_ndc", [](const DeepShadowMap& d) { return matrix_array(d.world_to_ndc); })
        .def("write_exr", [](const DeepShadowMap& d, const std::string& path) { write_deep_exr(d, path); }, py::arg("path"),
             "A scanline deep OpenEXR in OpenEXR's deep convention (docs/deep_exr.md).")
        .def("__repr__", [](const DeepShadowMap& d) {
            return "sombra.DeepShadowMap('" + d.light_name + "', " + std::to_string(d.width) + "x" + std::to_string(d.height) +
                   ", " + std::to_string(d.nodes.size()) + " nodes)";
        });
    m.def("read_deep_exr", &read_deep_exr, py::arg("path"),
          "Reads a deep OpenEXR as a DeepShadowMap: sombra's own (`sombra dsm`, DeepShadowMap.write_exr) and other tools' "
          "scanline deep files (docs/deep_exr.md); a hostile file is refused with one error line naming it.");
    m.def(
        "load_mesh",
        [](const std::string& path) {
            Mesh mesh;
            {
                py::gil_scoped_release release;
                mesh = load_mesh(path);
            }
            py::array_t<float> vertices({py::ssize_t(mesh.positions.size()), py::ssize_t(3)});
            py::array_t<std::uint32_t> triangles({py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
            std::copy_n(mesh.positions.data()->data(), mesh.positions.size() * 3, vertices.mutable_data());
            std::copy_n(mesh.triangles.data()->data(), mesh.triangles.size() * 3, triangles.mutable_data());
            return py::make_tuple(vertices, triangles);
        },
        py::arg("path"),
        "Reads an OBJ or PLY mesh as the scene files do (polygons as fans, OBJ corners welded): returns (vertices, "
        "triangles), float32 (N, 3) and uint32 (M, 3), ready for Scene.add_mesh. Errors name the file.");

    m.def(
        "write_image",
        [](const std::string& path, const py::object& image, const py::object& background) {
            auto a = checked_array<float>(image, "write_image", "image", {-1, -1, 4}, "a (height, width, 4) RGBA array",
                                          std::uint64_t(limits::kMaxImageSide) * limits::kMaxImageSide * 4);
            Image out;
            out.height = int(a.shape(0)), out.width = int(a.shape(1));
            if (out.width < 1 || out.height < 1) throw py::value_error("write_image: image: empty image " + shape_of(a));
            out.rgba.assign(a.data(), a.data() + a.size());
            out.background = vec3(background, "write_image", "background");
            py::gil_scoped_release release;
            write_image(out, path);
        },
        py::arg("path"), py::arg("image"), py::arg("background") = py::make_tuple(0, 0, 0),
        "Writes render()'s image as `sombra render -o` does: .png (8-bit sRGB) or .exr (linear float, premultiplied: "
        "the background composited into the image is taken out again; pass the scene's). No partial file on failure.");
    m.attr("__version__") = SOMBRA_VERSION;

    // render()'s result: a named tuple (image, stats), so `image, stats = render(…)` unpacks it, that
    // a notebook shows as the PNG `sombra render -o` writes (IPython's _repr_png_)
    py::exec(R"(
import collections as _collections, os as _os, tempfile as _tempfile

class Rendered(_collections.namedtuple("Rendered", ["image", "stats"])):
    """What render() returns: image (float32 (height, width, 4) linear RGBA, top row first) and stats
    (the dict `sombra render --stats` writes); unpacks as (image, stats). A notebook shows it as the
    8-bit sRGB PNG `sombra render -o image.png` writes."""
    __slots__ = ()

    def _repr_png_(self):
        with _tempfile.TemporaryDirectory() as folder:
            path = _os.path.join(folder, "image.png")
            write_image(path, self.image)
            with open(path, "rb") as f:
                return f.read()
)",
             m.attr("__dict__"));

    m.def(
        "build_deep_shadow_maps",
        [](Context& context, const Scene& scene, int light, const py::object& options, const py::kwargs& kwargs) {
            RenderOptions o = call_options(scene, options, kwargs, "build_deep_shadow_maps");
            RenderStats stats;
            std::vector<DeepShadowMap> maps;
            {
                py::gil_scoped_release release;
                maps = build_deep_shadow_maps(context, scene, light, o, &stats);
            }
            return py::make_tuple(maps, stats_dict(stats));
        },
        py::arg("context"), py::arg("scene"), py::arg("light"), py::arg("options") = py::none(),
        "The deep shadow maps of one light (1 view, or 6 cube faces of a point light); returns (maps, stats).");
}
