#include "dataset/io.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace maptune::dataset {
namespace fs = std::filesystem;

std::string read_file(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw DatasetError(file, "cannot open file (missing or unreadable)");
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void write_file(const fs::path& file, const std::string& bytes) {
    // A temporary name of this process and call: two processes writing one file (workers
    // sharing a cache directory) each rename a complete file, never one with the other's bytes.
    static std::atomic<std::uint64_t> counter{0};
    const fs::path tmp = file.string() + ".part-" + std::to_string(getpid()) + "-" + std::to_string(++counter);
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) throw DatasetError(file, "cannot create file");
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        if (!out) {
            std::error_code ec;
            fs::remove(tmp, ec);
            throw DatasetError(file, "write failed (disk full?)");
        }
    }
    std::error_code ec;
    fs::rename(tmp, file, ec);
    if (ec) {
        // The target is a directory, or not ours to replace: no temporary left behind.
        std::error_code ignore;
        fs::remove(tmp, ignore);
        throw DatasetError(file, "cannot write: " + ec.message());
    }
}

std::uint64_t fnv1a(const std::string& bytes, std::uint64_t h) {
    for (unsigned char c : bytes) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

std::string hex64(std::uint64_t v) {
    std::ostringstream ss;
    ss << std::hex << std::setw(16) << std::setfill('0') << v;
    return ss.str();
}

// ---------------------------------------------------------------- TUM

std::vector<StampedPose> read_tum(const fs::path& file) {
    std::istringstream in(read_file(file));
    std::vector<StampedPose> poses;
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const auto first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos || line[first] == '#') continue;
        std::istringstream ls(line);
        double v[8];
        for (double& x : v) {
            if (!(ls >> x)) {
                throw DatasetError(file, "line " + std::to_string(line_no) +
                                             ": expected 8 numbers 'timestamp tx ty tz qx qy qz qw'");
            }
        }
        for (double x : v) {
            if (!std::isfinite(x)) {
                throw DatasetError(file, "line " + std::to_string(line_no) + ": non-finite value");
            }
        }
        Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
        const double n = q.norm();
        if (std::abs(n - 1.0) > 1e-3) {
            throw DatasetError(file, "line " + std::to_string(line_no) +
                                         ": quaternion is not unit length (norm " +
                                         std::to_string(n) + ")");
        }
        StampedPose p;
        p.timestamp = v[0];
        p.T = Eigen::Isometry3d::Identity();
        p.T.linear() = q.normalized().toRotationMatrix();
        p.T.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
        poses.push_back(p);
    }
    return poses;
}

std::string format_tum(const std::vector<StampedPose>& poses) {
    std::ostringstream ss;
    ss << "# timestamp tx ty tz qx qy qz qw\n";
    char buf[256];
    for (const auto& p : poses) {
        Eigen::Quaterniond q(p.T.linear());
        q.normalize();
        if (q.w() < 0) q.coeffs() *= -1.0;  // one canonical sign keeps files byte-stable
        const Eigen::Vector3d t = p.T.translation();
        std::snprintf(buf, sizeof(buf), "%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", p.timestamp,
                      t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
        ss << buf;
    }
    return ss.str();
}

// ---------------------------------------------------------------- PCD write

namespace {

std::string pcd_header(const std::string& fields, const std::string& size,
                       const std::string& type, const std::string& count, std::size_t n) {
    std::ostringstream ss;
    ss << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " << fields
       << "\nSIZE " << size << "\nTYPE " << type << "\nCOUNT " << count << "\nWIDTH " << n
       << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA binary\n";
    return ss.str();
}

template <typename T>
void append_raw(std::string& s, const T& v) {
    s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

}  // namespace

std::string format_pcd_xyzrgb(const std::vector<ColoredPoint>& cloud) {
    std::string s = pcd_header("x y z rgb", "4 4 4 4", "F F F F", "1 1 1 1", cloud.size());
    s.reserve(s.size() + cloud.size() * 16);
    for (const auto& p : cloud) {
        append_raw(s, p.x);
        append_raw(s, p.y);
        append_raw(s, p.z);
        const std::uint32_t rgb = (std::uint32_t(p.r) << 16) | (std::uint32_t(p.g) << 8) | p.b;
        append_raw(s, rgb);
    }
    return s;
}

std::string format_pcd_xyz(const std::vector<Eigen::Vector3f>& points) {
    std::string s = pcd_header("x y z", "4 4 4", "F F F", "1 1 1", points.size());
    for (const auto& p : points) {
        append_raw(s, p.x());
        append_raw(s, p.y());
        append_raw(s, p.z());
    }
    return s;
}

// ---------------------------------------------------------------- readers

namespace {

struct Field {
    std::string name;
    int size = 4;
    char type = 'F';
    int count = 1;
    int offset = 0;  // bytes, within a binary record
};

double read_scalar(const char* p, char type, int size) {
    switch (type) {
        case 'F':
            if (size == 4) {
                float f;
                std::memcpy(&f, p, 4);
                return f;
            } else if (size == 8) {
                double d;
                std::memcpy(&d, p, 8);
                return d;
            }
            break;
        case 'U':
            if (size == 1) return static_cast<unsigned char>(*p);
            if (size == 2) { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
            if (size == 4) { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
            break;
        case 'I':
            if (size == 1) return static_cast<signed char>(*p);
            if (size == 2) { std::int16_t v; std::memcpy(&v, p, 2); return v; }
            if (size == 4) { std::int32_t v; std::memcpy(&v, p, 4); return v; }
            break;
    }
    return std::nan("");
}

void unpack_rgb(std::uint32_t v, ColoredPoint& p) {
    p.r = static_cast<std::uint8_t>((v >> 16) & 0xff);
    p.g = static_cast<std::uint8_t>((v >> 8) & 0xff);
    p.b = static_cast<std::uint8_t>(v & 0xff);
}

int find_field(const std::vector<Field>& fields, const std::string& name) {
    for (std::size_t i = 0; i < fields.size(); ++i) {
        if (fields[i].name == name) return static_cast<int>(i);
    }
    return -1;
}

// Coordinates beyond this are no submap of a robot's (±3e38 aborted inside PCL/FLANN's
// neighbour searches): the reader refuses them like NaN.
constexpr double kMaxCoordinate = 1e6;  // metres

// Collects points, checking finiteness; returns the count of dropped points.
struct Collector {
    const fs::path& file;
    const ReadOptions& options;
    std::vector<ColoredPoint> out;
    std::size_t nan_count = 0, far_count = 0;
    void add(double x, double y, double z, const ColoredPoint& colour) {
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
            ++nan_count;
            return;
        }
        if (std::fabs(x) > kMaxCoordinate || std::fabs(y) > kMaxCoordinate || std::fabs(z) > kMaxCoordinate) {
            ++far_count;
            return;
        }
        ColoredPoint p = colour;
        p.x = static_cast<float>(x);
        p.y = static_cast<float>(y);
        p.z = static_cast<float>(z);
        out.push_back(p);
    }
    std::vector<ColoredPoint> finish() {
        if (nan_count > 0 && !options.drop_nan) {
            throw DatasetError(file, std::to_string(nan_count) +
                                         " points with NaN/Inf coordinates (use --drop-nan to "
                                         "drop them)");
        }
        if (far_count > 0) {
            throw DatasetError(file, std::to_string(far_count) + " points with a coordinate beyond ±" +
                                         std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
        }
        if (out.empty()) throw DatasetError(file, "empty cloud: no valid points");
        return std::move(out);
    }
};

std::vector<ColoredPoint> read_pcd(const fs::path& file, const ReadOptions& options) {
    const std::string bytes = read_file(file);
    std::size_t pos = 0;
    std::vector<Field> fields;
    std::size_t points = 0;
    bool have_points = false;
    std::string data;
    while (pos < bytes.size()) {
        const std::size_t eol = bytes.find('\n', pos);
        if (eol == std::string::npos) throw DatasetError(file, "truncated PCD header");
        std::string line = bytes.substr(pos, eol - pos);
        pos = eol + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        std::string key;
        ls >> key;
        if (key == "FIELDS") {
            std::string n;
            while (ls >> n) fields.push_back(Field{n});
        } else if (key == "SIZE") {
            for (auto& f : fields) ls >> f.size;
        } else if (key == "TYPE") {
            for (auto& f : fields) ls >> f.type;
        } else if (key == "COUNT") {
            for (auto& f : fields) ls >> f.count;
        } else if (key == "POINTS") {
            ls >> points;
            have_points = true;
        } else if (key == "DATA") {
            ls >> data;
            break;
        }
    }
    if (data.empty()) throw DatasetError(file, "not a PCD file (no DATA line in header)");
    if (!have_points) throw DatasetError(file, "PCD header lacks POINTS");
    const int ix = find_field(fields, "x"), iy = find_field(fields, "y"),
              iz = find_field(fields, "z");
    if (ix < 0 || iy < 0 || iz < 0) throw DatasetError(file, "PCD lacks fields x y z");
    int irgb = find_field(fields, "rgb");
    if (irgb < 0) irgb = find_field(fields, "rgba");
    // Sizes, types and counts index the data: a hostile header must fail here, not read out of
    // bounds below.
    int record = 0;
    for (auto& f : fields) {
        if (f.size != 1 && f.size != 2 && f.size != 4 && f.size != 8) {
            throw DatasetError(file, "PCD field " + f.name + ": SIZE " + std::to_string(f.size) + " is not 1, 2, 4 or 8");
        }
        if (f.type != 'F' && f.type != 'I' && f.type != 'U') {
            throw DatasetError(file, "PCD field " + f.name + ": TYPE " + std::string(1, f.type) + " is not F, I or U");
        }
        if (f.count < 1 || f.count > 100000) {
            throw DatasetError(file, "PCD field " + f.name + ": COUNT " + std::to_string(f.count) + " is not in 1..100000");
        }
        f.offset = record;
        record += f.size * f.count;
    }
    for (const int i : {ix, iy, iz}) {
        const auto& f = fields[static_cast<std::size_t>(i)];
        // Coordinates are metres as floats; an integer TYPE would read float data as integers
        // and give a silently wrong cloud.
        if (f.type != 'F') {
            throw DatasetError(file, "PCD field " + f.name + ": TYPE " + std::string(1, f.type) +
                                         ": coordinates must be floats (TYPE F)");
        }
        if (f.size < 4) throw DatasetError(file, "PCD field " + f.name + ": a float of SIZE " + std::to_string(f.size));
    }
    if (irgb >= 0 && fields[static_cast<std::size_t>(irgb)].size != 4) {
        throw DatasetError(file, "PCD field " + fields[static_cast<std::size_t>(irgb)].name + ": SIZE must be 4");
    }
    // A point takes at least two bytes of the file: more announced points cannot be there.
    if (points > bytes.size()) {
        throw DatasetError(file, "PCD header announces " + std::to_string(points) + " points in a file of " +
                                     std::to_string(bytes.size()) + " bytes");
    }
    Collector c{file, options, {}, 0};
    c.out.reserve(points);
    ColoredPoint grey;
    grey.r = grey.g = grey.b = 128;
    if (data == "binary") {
        const std::size_t need = points * static_cast<std::size_t>(record);
        if (bytes.size() - pos < need) {
            throw DatasetError(file, "truncated: header announces " + std::to_string(points) +
                                         " points (" + std::to_string(need) +
                                         " bytes) but only " + std::to_string(bytes.size() - pos) +
                                         " bytes of data follow");
        }
        for (std::size_t i = 0; i < points; ++i) {
            const char* r = bytes.data() + pos + i * record;
            ColoredPoint col = grey;
            if (irgb >= 0) {
                std::uint32_t v;
                std::memcpy(&v, r + fields[irgb].offset, 4);
                unpack_rgb(v, col);
            }
            c.add(read_scalar(r + fields[ix].offset, fields[ix].type, fields[ix].size),
                  read_scalar(r + fields[iy].offset, fields[iy].type, fields[iy].size),
                  read_scalar(r + fields[iz].offset, fields[iz].type, fields[iz].size), col);
        }
    } else if (data == "ascii") {
        std::istringstream in(bytes.substr(pos));
        std::string line;
        std::size_t n = 0;
        while (n < points && std::getline(in, line)) {
            if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
            std::istringstream ls(line);
            std::vector<std::string> tok;
            std::string t;
            while (ls >> t) tok.push_back(t);
            // Column index of each field (COUNT > 1 spans several columns).
            auto column = [&](int fi) {
                int col = 0;
                for (int k = 0; k < fi; ++k) col += fields[k].count;
                return col;
            };
            if (static_cast<int>(tok.size()) < column(static_cast<int>(fields.size()) - 1) + 1) {
                throw DatasetError(file, "ascii data line " + std::to_string(n + 1) +
                                             " has too few values");
            }
            auto num = [&](int fi) {
                const std::string& s = tok[column(fi)];
                if (s == "nan" || s == "NaN" || s == "-nan") return std::nan("");
                char* end = nullptr;
                const double v = std::strtod(s.c_str(), &end);
                if (end == s.c_str() || *end != '\0') {
                    throw DatasetError(file, "ascii data line " + std::to_string(n + 1) + ": '" + s + "' is not a number");
                }
                return v;
            };
            ColoredPoint col = grey;
            if (irgb >= 0) {
                const std::string& s = tok[column(irgb)];
                std::uint32_t v = 0;
                if (fields[irgb].type == 'F') {
                    float f = std::strtof(s.c_str(), nullptr);
                    std::memcpy(&v, &f, 4);
                } else {
                    v = static_cast<std::uint32_t>(std::strtoul(s.c_str(), nullptr, 10));
                }
                unpack_rgb(v, col);
            }
            c.add(num(ix), num(iy), num(iz), col);
            ++n;
        }
        if (n < points) {
            throw DatasetError(file, "truncated: header announces " + std::to_string(points) +
                                         " points but only " + std::to_string(n) + " follow");
        }
    } else {
        throw DatasetError(file, "unsupported PCD DATA '" + data +
                                     "' (use ascii or binary, e.g. pcl_convert_pcd_ascii_binary)");
    }
    return c.finish();
}

struct PlyProperty {
    std::string name;
    std::string type;
    bool is_list = false;
    std::string count_type;
};
struct PlyElement {
    std::string name;
    std::size_t count = 0;
    std::vector<PlyProperty> props;
};

int ply_type_size(const std::string& t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" ||
        t == "float32")
        return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
}

double ply_read_binary(const char* p, const std::string& t) {
    if (t == "float" || t == "float32") { float v; std::memcpy(&v, p, 4); return v; }
    if (t == "double" || t == "float64") { double v; std::memcpy(&v, p, 8); return v; }
    if (t == "uchar" || t == "uint8") return static_cast<unsigned char>(*p);
    if (t == "char" || t == "int8") return static_cast<signed char>(*p);
    if (t == "ushort" || t == "uint16") { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
    if (t == "short" || t == "int16") { std::int16_t v; std::memcpy(&v, p, 2); return v; }
    if (t == "uint" || t == "uint32") { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
    if (t == "int" || t == "int32") { std::int32_t v; std::memcpy(&v, p, 4); return v; }
    return std::nan("");
}

std::vector<ColoredPoint> read_ply(const fs::path& file, const ReadOptions& options) {
    const std::string bytes = read_file(file);
    if (bytes.compare(0, 3, "ply") != 0) throw DatasetError(file, "not a PLY file (no 'ply' magic)");
    std::size_t pos = 0;
    std::string format;
    std::vector<PlyElement> elements;
    bool ended = false;
    while (pos < bytes.size()) {
        const std::size_t eol = bytes.find('\n', pos);
        if (eol == std::string::npos) break;
        std::string line = bytes.substr(pos, eol - pos);
        pos = eol + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream ls(line);
        std::string key;
        ls >> key;
        if (key == "format") {
            ls >> format;
        } else if (key == "element") {
            PlyElement e;
            ls >> e.name >> e.count;
            elements.push_back(e);
        } else if (key == "property" && !elements.empty()) {
            PlyProperty p;
            std::string t;
            ls >> t;
            if (t == "list") {
                p.is_list = true;
                ls >> p.count_type >> p.type >> p.name;
            } else {
                p.type = t;
                ls >> p.name;
            }
            elements.back().props.push_back(p);
        } else if (key == "end_header") {
            ended = true;
            break;
        }
    }
    if (!ended) throw DatasetError(file, "truncated PLY header (no end_header)");
    if (format != "ascii" && format != "binary_little_endian") {
        throw DatasetError(file, "unsupported PLY format '" + format +
                                     "' (ascii or binary_little_endian)");
    }
    // Counts and types drive the reading loops: check them against the file before reading.
    for (const auto& e : elements) {
        if (e.count > bytes.size()) {
            throw DatasetError(file, "PLY element '" + e.name + "' announces " + std::to_string(e.count) +
                                         " entries in a file of " + std::to_string(bytes.size()) + " bytes");
        }
        if (format != "ascii" && e.props.empty() && e.count > 0) {
            throw DatasetError(file, "PLY element '" + e.name + "' has entries but no properties");
        }
        for (const auto& p : e.props) {
            if (ply_type_size(p.type) == 0 || (p.is_list && ply_type_size(p.count_type) == 0)) {
                throw DatasetError(file, "PLY element '" + e.name + "' property '" + p.name + "': unknown type '" +
                                             (p.is_list && ply_type_size(p.count_type) == 0 ? p.count_type : p.type) + "'");
            }
        }
    }
    Collector c{file, options, {}, 0};
    ColoredPoint grey;
    grey.r = grey.g = grey.b = 128;
    std::istringstream ascii(format == "ascii" ? bytes.substr(pos) : std::string());
    for (const auto& e : elements) {
        const bool is_vertex = e.name == "vertex";
        auto idx = [&](const std::string& n) {
            for (std::size_t i = 0; i < e.props.size(); ++i) {
                if (e.props[i].name == n) return static_cast<int>(i);
            }
            return -1;
        };
        const int ix = idx("x"), iy = idx("y"), iz = idx("z");
        const int ir = idx("red"), ig = idx("green"), ib = idx("blue");
        if (is_vertex && (ix < 0 || iy < 0 || iz < 0)) {
            throw DatasetError(file, "PLY vertex element lacks x y z");
        }
        if (is_vertex) c.out.reserve(e.count);
        std::vector<double> vals(e.props.size());
        for (std::size_t i = 0; i < e.count; ++i) {
            if (format == "ascii") {
                std::string line;
                do {
                    if (!std::getline(ascii, line)) {
                        throw DatasetError(file, "truncated: element '" + e.name + "' announces " +
                                                     std::to_string(e.count) + " entries, found " +
                                                     std::to_string(i));
                    }
                } while (line.find_first_not_of(" \t\r") == std::string::npos);
                if (!is_vertex) continue;
                std::istringstream ls(line);
                for (std::size_t k = 0; k < e.props.size(); ++k) {
                    std::string s;
                    if (!(ls >> s)) {
                        throw DatasetError(file, "vertex " + std::to_string(i) +
                                                     " has too few values");
                    }
                    vals[k] = (s == "nan" || s == "NaN") ? std::nan("") : std::strtod(s.c_str(), nullptr);
                    if (e.props[k].is_list) {
                        throw DatasetError(file, "list properties in vertex are not supported");
                    }
                }
            } else {
                for (std::size_t k = 0; k < e.props.size(); ++k) {
                    const auto& p = e.props[k];
                    if (p.is_list) {
                        const int cs = ply_type_size(p.count_type), vs = ply_type_size(p.type);
                        if (pos + cs > bytes.size()) throw DatasetError(file, "truncated binary PLY data");
                        const double listed = ply_read_binary(bytes.data() + pos, p.count_type);
                        if (!(listed >= 0) || listed * vs > static_cast<double>(bytes.size() - pos - cs)) {
                            throw DatasetError(file, "truncated binary PLY data (a list of " + std::to_string(listed) + " entries)");
                        }
                        pos += cs + static_cast<std::size_t>(listed) * vs;
                        vals[k] = 0;
                    } else {
                        const int sz = ply_type_size(p.type);
                        if (sz == 0) throw DatasetError(file, "unknown PLY type '" + p.type + "'");
                        if (pos + sz > bytes.size()) {
                            throw DatasetError(file, "truncated: binary data ends inside element '" +
                                                         e.name + "' entry " + std::to_string(i) +
                                                         " of " + std::to_string(e.count));
                        }
                        vals[k] = ply_read_binary(bytes.data() + pos, p.type);
                        pos += sz;
                    }
                }
                if (!is_vertex) continue;
            }
            ColoredPoint col = grey;
            if (ir >= 0 && ig >= 0 && ib >= 0) {
                col.r = static_cast<std::uint8_t>(std::clamp(vals[ir], 0.0, 255.0));
                col.g = static_cast<std::uint8_t>(std::clamp(vals[ig], 0.0, 255.0));
                col.b = static_cast<std::uint8_t>(std::clamp(vals[ib], 0.0, 255.0));
            }
            c.add(vals[ix], vals[iy], vals[iz], col);
        }
        // Only the vertex element matters; later elements (faces, range grids) are skipped.
        if (is_vertex) break;
    }
    return c.finish();
}

std::string lower_ext(const fs::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    return ext;
}

}  // namespace

std::vector<ColoredPoint> read_cloud(const fs::path& file, const ReadOptions& options) {
    const std::string ext = lower_ext(file);
    if (ext == ".pcd") return read_pcd(file, options);
    if (ext == ".ply") return read_ply(file, options);
    throw DatasetError(file, "unknown cloud format '" + ext + "' (expected .pcd or .ply)");
}

std::vector<Eigen::Vector3f> read_points(const fs::path& file, const ReadOptions& options) {
    std::vector<Eigen::Vector3f> out;
    std::vector<ColoredPoint> c;
    try {
        c = read_cloud(file, options);
    } catch (const DatasetError& e) {
        // An empty obstacle set is legitimate (a featureless submap).
        if (std::string(e.what()).find("empty cloud") == std::string::npos) throw;
    }
    out.reserve(c.size());
    for (const auto& p : c) out.emplace_back(p.x, p.y, p.z);
    return out;
}

}  // namespace maptune::dataset
