// Embree 3 peer of raylab's bunny benchmark (issue 11). Not part of the cargo workspace: built by
// benches/peers/run.sh with g++ against Debian's libembree-dev (3.13).
//
//   bunny_embree render MESH.obj --camera PX PY PZ TX TY TZ FOV --light DX DY DZ [--plane Y]
//                 [--width 800] [--height 600] [--threads N] [--quality medium|high] [--robust]
//                 [--packet 1|4|8|16] [--device CONFIG] [--repeat N] [--ppm OUT.ppm]
//   bunny_embree load MESH.obj [--quality medium|high] [--robust]
//
// `render` traces, per pixel, one camera ray through the pixel centre (rtcIntersect1) and, on a
// hit, one shadow ray toward the directional light (rtcOccluded1), exactly the work of raylab's
// bunny scene with `avoid = false` (a shadow ray at every hit, also where the light is behind the
// surface). The ground plane y = Y is raylab's infinite `plane`, intersected analytically here
// (one division per ray; Embree only holds the mesh), so both renderers see the same geometry.
// Shading is raylab's Phong with ks = 0: ambient + kd·max(0, n·l)·visible, written sRGB-encoded
// to the PPM so the two images can be compared pixel by pixel.
//
// Threads: std::thread workers take bands of 8 rows from an atomic counter (like rayon's work
// stealing in raylab). In each band the camera rays are traced first, then the shadow rays of
// that band's hits, each phase timed by the thread's CPU clock; the frame is timed by the wall
// clock. Embree's own (TBB) threads are used for the BVH build only.
//
// `--packet N` (4, 8 or 16; default 1) traces the same rays as packets of N: the camera rays of N
// neighbouring pixels of a row (`rtcIntersectN`; the last packet of a row has fewer valid lanes),
// then the band's shadow rays N at a time in the order the single-ray path traces them
// (`rtcOccludedN`; a ray the plane blocks is an invalid lane). Same counts, same image; it is the
// "8-wide packets" row of issue 29's targets (`benches/peers/profile.sh` profiles both).
//
// `--device CONFIG` is handed to rtcNewDevice, e.g. "max_isa=avx2": the code valgrind runs (it has
// no AVX-512), so a native run's instruction rate can be set beside callgrind's count.
//
// `load` reads the OBJ (one pass over the bytes, read whole into memory), builds the scene and
// exits: time it and its peak memory with /usr/bin/time -v.

#include <embree3/rtcore.h>

#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <string>
#include <sys/resource.h>
#include <thread>
#include <type_traits>
#include <vector>

namespace {

[[noreturn]] void die(const std::string &msg) {
    std::fprintf(stderr, "bunny_embree: %s\n", msg.c_str());
    std::exit(2);
}

double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double thread_cpu_s() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double process_cpu_s() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

long peak_rss_kib() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss;
}

// ---------------------------------------------------------------------------------------------
// Minimal OBJ reader: `v x y z` and `f a b c ...` (a polygon is fanned into triangles; `a/b/c`
// forms and negative indices are accepted; every other line is skipped). Errors name the line.

struct Mesh {
    std::vector<float> positions;  // x y z per vertex, plus one float of padding (Embree reads 16 B)
    std::vector<uint32_t> indices; // three per triangle
    size_t vertex_count() const { return positions.size() / 3; }
};

Mesh read_obj(const std::string &path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) die("cannot open " + path);
    const std::streamsize size = in.tellg();
    std::string bytes(size_t(size), '\0');
    in.seekg(0);
    if (!in.read(bytes.data(), size)) die("cannot read " + path);

    Mesh m;
    m.positions.reserve(size_t(size) / 12);
    m.indices.reserve(size_t(size) / 8);
    const char *p = bytes.data();
    const char *end = p + bytes.size();
    size_t line = 0;
    std::vector<int64_t> face;
    auto skip_blanks = [&](const char *q) {
        while (q < end && (*q == ' ' || *q == '\t' || *q == '\r')) ++q;
        return q;
    };
    while (p < end) {
        ++line;
        const char *eol = static_cast<const char *>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol) eol = end;
        const char *q = skip_blanks(p);
        if (q + 1 < eol && q[0] == 'v' && (q[1] == ' ' || q[1] == '\t')) {
            q += 2;
            for (int k = 0; k < 3; ++k) {
                q = skip_blanks(q);
                float x = 0;
                auto r = std::from_chars(q, eol, x);
                if (r.ec != std::errc() || !std::isfinite(x))
                    die(path + ":" + std::to_string(line) + ": expected 3 finite vertex coordinates");
                m.positions.push_back(x);
                q = r.ptr;
            }
        } else if (q + 1 < eol && q[0] == 'f' && (q[1] == ' ' || q[1] == '\t')) {
            q += 2;
            face.clear();
            const int64_t nv = int64_t(m.positions.size() / 3);
            while (true) {
                q = skip_blanks(q);
                if (q >= eol) break;
                int64_t idx = 0;
                auto r = std::from_chars(q, eol, idx);
                if (r.ec != std::errc()) die(path + ":" + std::to_string(line) + ": expected a vertex index");
                q = r.ptr;
                while (q < eol && *q != ' ' && *q != '\t' && *q != '\r') ++q; // skip /vt/vn
                const int64_t zero_based = idx > 0 ? idx - 1 : nv + idx;
                if (idx == 0 || zero_based < 0 || zero_based >= nv)
                    die(path + ":" + std::to_string(line) + ": vertex index " + std::to_string(idx) + " out of range");
                face.push_back(zero_based);
            }
            if (face.size() < 3) die(path + ":" + std::to_string(line) + ": a face needs at least 3 vertices");
            for (size_t k = 1; k + 1 < face.size(); ++k) {
                m.indices.push_back(uint32_t(face[0]));
                m.indices.push_back(uint32_t(face[k]));
                m.indices.push_back(uint32_t(face[k + 1]));
            }
        }
        p = eol + 1;
    }
    if (m.indices.empty()) die(path + ": no triangles");
    m.positions.push_back(0.0f); // padding: Embree may load the last vertex with a 16-byte read
    return m;
}

// ---------------------------------------------------------------------------------------------

struct Options {
    std::string mode, mesh, ppm, device;
    double cam[7] = {0, 0, 1, 0, 0, 0, 45};
    double light[3] = {0, -1, 0};
    bool plane = false;
    double plane_y = 0;
    int width = 800, height = 600, threads = 1;
    RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM;
    bool robust = false;
    int packet = 1;
    int repeat = 1;
};

Options parse_args(int argc, char **argv) {
    if (argc < 3) die("usage: bunny_embree render|load MESH.obj [options] (see the source's header)");
    Options o;
    o.mode = argv[1];
    o.mesh = argv[2];
    if (o.mode != "render" && o.mode != "load") die("mode must be render or load, not " + o.mode);
    auto num = [&](int &i) {
        if (++i >= argc) die(std::string("missing value after ") + argv[i - 1]);
        char *e = nullptr;
        double v = std::strtod(argv[i], &e);
        if (*e || !std::isfinite(v)) die(std::string("expected a number, found ") + argv[i]);
        return v;
    };
    for (int i = 3; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--camera") for (double &c : o.cam) c = num(i);
        else if (a == "--light") for (double &c : o.light) c = num(i);
        else if (a == "--plane") { o.plane = true; o.plane_y = num(i); }
        else if (a == "--width") o.width = int(num(i));
        else if (a == "--height") o.height = int(num(i));
        else if (a == "--threads") o.threads = int(num(i));
        else if (a == "--robust") o.robust = true;
        else if (a == "--packet") {
            o.packet = int(num(i));
            if (o.packet != 1 && o.packet != 4 && o.packet != 8 && o.packet != 16) die("--packet: 1, 4, 8 or 16");
        }
        else if (a == "--repeat") { o.repeat = int(num(i)); if (o.repeat < 1 || o.repeat > 100000) die("--repeat: 1..100000"); }
        else if (a == "--device") { if (++i >= argc) die("missing value after --device"); o.device = argv[i]; }
        else if (a == "--ppm") { if (++i >= argc) die("missing file after --ppm"); o.ppm = argv[i]; }
        else if (a == "--quality") {
            if (++i >= argc) die("missing value after --quality");
            std::string q = argv[i];
            if (q == "medium") o.quality = RTC_BUILD_QUALITY_MEDIUM;
            else if (q == "high") o.quality = RTC_BUILD_QUALITY_HIGH;
            else die("--quality: medium or high, not " + q);
        } else die("unknown option " + a);
    }
    if (o.width < 1 || o.height < 1 || o.width > 32768 || o.height > 32768) die("bad image size");
    if (o.threads < 1 || o.threads > 256) die("--threads: 1..256");
    return o;
}

struct V3 {
    double x, y, z;
    V3 operator+(V3 b) const { return {x + b.x, y + b.y, z + b.z}; }
    V3 operator-(V3 b) const { return {x - b.x, y - b.y, z - b.z}; }
    V3 operator*(double s) const { return {x * s, y * s, z * s}; }
    double dot(V3 b) const { return x * b.x + y * b.y + z * b.z; }
    V3 cross(V3 b) const { return {y * b.z - z * b.y, z * b.x - x * b.z, x * b.y - y * b.x}; }
    V3 normalized() const { double l = std::sqrt(dot(*this)); return {x / l, y / l, z / l}; }
};

// raylab's look-at camera (src/camera.rs): vertical fov, screen at the look-at distance, pixel
// (x, y) through film position (x + 0.5, y + 0.5), y down.
struct Camera {
    V3 pos, to, up, right;
    double sw, sh, dist;
    Camera(const Options &o) {
        pos = {o.cam[0], o.cam[1], o.cam[2]};
        V3 target{o.cam[3], o.cam[4], o.cam[5]};
        dist = std::sqrt((target - pos).dot(target - pos));
        to = (target - pos).normalized();
        V3 y{0, 1, 0};
        up = (y - to * y.dot(to)).normalized();
        right = to.cross(up);
        sh = 2.0 * dist * std::tan(o.cam[6] * M_PI / 180.0 * 0.5);
        sw = sh * double(o.width) / double(o.height);
    }
    V3 dir(int x, int y, int nx, int ny) const {
        double rx = sw / nx, ry = sh / ny;
        V3 pc = pos + to * dist;
        V3 p = pc + right * ((x + 0.5 - nx / 2.0) * rx) - up * ((y + 0.5 - ny / 2.0) * ry);
        return (p - pos).normalized();
    }
};

uint8_t srgb8(double v) {
    v = v < 0 ? 0 : (v > 1 ? 1 : v);
    double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    return uint8_t(s * 255.0 + 0.5);
}

RTCScene build_scene(RTCDevice dev, const Mesh &m, const Options &o) {
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneBuildQuality(scene, o.quality);
    if (o.robust) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, o.quality);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0,
                               3 * sizeof(float), m.vertex_count());
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.indices.data(), 0,
                               3 * sizeof(uint32_t), m.indices.size() / 3);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) die("Embree reported an error while building");
    return scene;
}

// Material and lights of benches/peers/bunny/bunny.toml.
constexpr double KD_BUNNY = 0.8, KD_GROUND = 0.6, KA = 1.0, AMBIENT = 0.1, LIGHT = 1.0;

struct Counts {
    uint64_t camera = 0, hits_mesh = 0, hits_plane = 0, shadow = 0, occluded = 0;
    double camera_cpu = 0, shadow_cpu = 0;
};

struct PendingShadow {
    float px, py, pz;
    float nl; // n·l with n facing the viewer (≤ 0: the light is behind the surface)
    double kd;
    uint32_t pixel;
};

// Packets of N rays: Embree's fixed-size entry points, on the SOA layout of RTCRayHitNt<N>
// (the same layout as RTCRayHit4/8/16; Embree wants the packet aligned to its size).
template <int N> void intersect_n(const int *valid, RTCScene s, RTCIntersectContext *c, RTCRayHitNt<N> *rh) {
    if constexpr (N == 4) rtcIntersect4(valid, s, c, reinterpret_cast<RTCRayHit4 *>(rh));
    else if constexpr (N == 8) rtcIntersect8(valid, s, c, reinterpret_cast<RTCRayHit8 *>(rh));
    else rtcIntersect16(valid, s, c, reinterpret_cast<RTCRayHit16 *>(rh));
}
template <int N> void occluded_n(const int *valid, RTCScene s, RTCIntersectContext *c, RTCRayNt<N> *r) {
    if constexpr (N == 4) rtcOccluded4(valid, s, c, reinterpret_cast<RTCRay4 *>(r));
    else if constexpr (N == 8) rtcOccluded8(valid, s, c, reinterpret_cast<RTCRay8 *>(r));
    else rtcOccluded16(valid, s, c, reinterpret_cast<RTCRay16 *>(r));
}

int render(const Options &o) {
    RTCDevice dev = rtcNewDevice(o.device.empty() ? nullptr : o.device.c_str());
    if (!dev) die("rtcNewDevice failed");
    double t0 = now_s();
    Mesh mesh = read_obj(o.mesh);
    double t1 = now_s();
    RTCScene scene = build_scene(dev, mesh, o);
    double t2 = now_s();

    const Camera cam(o);
    const V3 to_light = (V3{-o.light[0], -o.light[1], -o.light[2]}).normalized();
    const int W = o.width, H = o.height, band = 8;
    const int bands = (H + band - 1) / band;
    // Shadow-ray start: the hit point moved along the ray's tnear, 1e-5 of the camera's distance
    // to its target (far above f32 rounding at this scale, far below any feature of the bunny).
    const float tnear_shadow = float(1e-5 * cam.dist);
    std::vector<uint8_t> image(size_t(W) * H * 3, 0);
    std::vector<Counts> counts(size_t(o.threads));
    std::atomic<int> next{0};

    // One band as packets of N (see `--packet`): the same rays, hits and shading as the single-ray
    // band below.
    auto packet_band = [&](auto n_tag, int b, Counts &c, std::vector<PendingShadow> &pending, RTCIntersectContext &ctx) {
        constexpr int N = decltype(n_tag)::value;
        alignas(64) RTCRayHitNt<N> rh;
        alignas(64) RTCRayNt<N> sr;
        alignas(64) int valid[N];
        float tplanes[N];
        int xs[N];
        V3 ds[N];
        const double ta = thread_cpu_s();
        pending.clear();
        for (int y = b * band; y < std::min(H, (b + 1) * band); ++y) {
            for (int x0 = 0; x0 < W; x0 += N) {
                for (int k = 0; k < N; ++k) {
                    const int x = x0 + k;
                    valid[k] = x < W ? -1 : 0;
                    const V3 d = cam.dir(x < W ? x : W - 1, y, W, H);
                    float tplane = INFINITY;
                    if (o.plane && d.y != 0.0) {
                        double t = (o.plane_y - cam.pos.y) / d.y;
                        if (t > 0) tplane = float(t);
                    }
                    xs[k] = x; ds[k] = d; tplanes[k] = tplane;
                    rh.ray.org_x[k] = float(cam.pos.x); rh.ray.org_y[k] = float(cam.pos.y); rh.ray.org_z[k] = float(cam.pos.z);
                    rh.ray.dir_x[k] = float(d.x); rh.ray.dir_y[k] = float(d.y); rh.ray.dir_z[k] = float(d.z);
                    rh.ray.tnear[k] = 0.0f;
                    rh.ray.tfar[k] = tplane;
                    rh.ray.mask[k] = 0xFFFFFFFFu;
                    rh.ray.time[k] = 0.0f;
                    rh.ray.id[k] = 0;
                    rh.ray.flags[k] = 0;
                    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                }
                intersect_n<N>(valid, scene, &ctx, &rh);
                for (int k = 0; k < N && valid[k]; ++k) {
                    ++c.camera;
                    const uint32_t pixel = uint32_t(y) * W + xs[k];
                    V3 n;
                    double kd;
                    if (rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) {
                        ++c.hits_mesh;
                        n = V3{rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]}.normalized();
                        kd = KD_BUNNY;
                    } else if (std::isfinite(tplanes[k])) {
                        ++c.hits_plane;
                        n = {0, 1, 0};
                        kd = KD_GROUND;
                    } else {
                        continue;
                    }
                    if (n.dot(ds[k]) > 0) n = n * -1.0;
                    const float t = rh.ray.tfar[k];
                    pending.push_back({rh.ray.org_x[k] + t * rh.ray.dir_x[k], rh.ray.org_y[k] + t * rh.ray.dir_y[k],
                                       rh.ray.org_z[k] + t * rh.ray.dir_z[k], float(n.dot(to_light)), kd, pixel});
                }
            }
        }
        const double tb = thread_cpu_s();
        bool blocked[N];
        for (size_t i0 = 0; i0 < pending.size(); i0 += N) {
            for (int k = 0; k < N; ++k) {
                const size_t i = i0 + size_t(k);
                const PendingShadow &s = pending[i < pending.size() ? i : pending.size() - 1];
                sr.org_x[k] = s.px; sr.org_y[k] = s.py; sr.org_z[k] = s.pz;
                sr.dir_x[k] = float(to_light.x); sr.dir_y[k] = float(to_light.y); sr.dir_z[k] = float(to_light.z);
                sr.tnear[k] = tnear_shadow;
                sr.tfar[k] = INFINITY;
                sr.mask[k] = 0xFFFFFFFFu;
                sr.time[k] = 0.0f;
                sr.id[k] = 0;
                sr.flags[k] = 0;
                blocked[k] = false;
                if (o.plane && to_light.y != 0.0) {
                    double tp = (o.plane_y - double(s.py)) / to_light.y;
                    blocked[k] = tp > tnear_shadow;
                }
                valid[k] = (i < pending.size() && !blocked[k]) ? -1 : 0;
            }
            occluded_n<N>(valid, scene, &ctx, &sr);
            for (int k = 0; k < N && i0 + size_t(k) < pending.size(); ++k) {
                const PendingShadow &s = pending[i0 + size_t(k)];
                const bool bl = blocked[k] || sr.tfar[k] < 0.0f;
                ++c.shadow;
                c.occluded += bl;
                const double lit = (!bl && s.nl > 0) ? s.kd * s.nl * LIGHT : 0.0;
                const uint8_t v = srgb8(KA * AMBIENT + lit);
                image[size_t(s.pixel) * 3 + 0] = image[size_t(s.pixel) * 3 + 1] = image[size_t(s.pixel) * 3 + 2] = v;
            }
        }
        const double tc = thread_cpu_s();
        c.camera_cpu += tb - ta;
        c.shadow_cpu += tc - tb;
    };

    auto worker = [&](int tid) {
        Counts &c = counts[size_t(tid)];
        std::vector<PendingShadow> pending;
        pending.reserve(size_t(W) * band);
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (int b; (b = next.fetch_add(1)) < bands;) {
            if (o.packet == 4) { packet_band(std::integral_constant<int, 4>{}, b, c, pending, ctx); continue; }
            if (o.packet == 8) { packet_band(std::integral_constant<int, 8>{}, b, c, pending, ctx); continue; }
            if (o.packet == 16) { packet_band(std::integral_constant<int, 16>{}, b, c, pending, ctx); continue; }
            const double ta = thread_cpu_s();
            pending.clear();
            for (int y = b * band; y < std::min(H, (b + 1) * band); ++y) {
                for (int x = 0; x < W; ++x) {
                    const V3 d = cam.dir(x, y, W, H);
                    float tplane = INFINITY;
                    if (o.plane && d.y != 0.0) {
                        double t = (o.plane_y - cam.pos.y) / d.y;
                        if (t > 0) tplane = float(t);
                    }
                    RTCRayHit rh;
                    rh.ray.org_x = float(cam.pos.x); rh.ray.org_y = float(cam.pos.y); rh.ray.org_z = float(cam.pos.z);
                    rh.ray.dir_x = float(d.x); rh.ray.dir_y = float(d.y); rh.ray.dir_z = float(d.z);
                    rh.ray.tnear = 0.0f;
                    rh.ray.tfar = tplane;
                    rh.ray.mask = 0xFFFFFFFFu;
                    rh.ray.time = 0.0f;
                    rh.ray.flags = 0;
                    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                    rtcIntersect1(scene, &ctx, &rh);
                    ++c.camera;
                    const uint32_t pixel = uint32_t(y) * W + x;
                    V3 n;
                    double kd;
                    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
                        ++c.hits_mesh;
                        n = V3{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z}.normalized();
                        kd = KD_BUNNY;
                    } else if (std::isfinite(tplane)) {
                        ++c.hits_plane;
                        n = {0, 1, 0};
                        kd = KD_GROUND;
                    } else {
                        continue; // background stays black
                    }
                    if (n.dot(d) > 0) n = n * -1.0;
                    const float t = rh.ray.tfar;
                    pending.push_back({rh.ray.org_x + t * rh.ray.dir_x, rh.ray.org_y + t * rh.ray.dir_y,
                                       rh.ray.org_z + t * rh.ray.dir_z, float(n.dot(to_light)), kd, pixel});
                }
            }
            const double tb = thread_cpu_s();
            for (const PendingShadow &s : pending) {
                RTCRay r;
                r.org_x = s.px; r.org_y = s.py; r.org_z = s.pz;
                r.dir_x = float(to_light.x); r.dir_y = float(to_light.y); r.dir_z = float(to_light.z);
                r.tnear = tnear_shadow;
                r.tfar = INFINITY;
                r.mask = 0xFFFFFFFFu;
                r.time = 0.0f;
                r.flags = 0;
                bool blocked = false;
                if (o.plane && to_light.y != 0.0) {
                    double tp = (o.plane_y - double(s.py)) / to_light.y;
                    blocked = tp > tnear_shadow;
                }
                if (!blocked) {
                    rtcOccluded1(scene, &ctx, &r);
                    blocked = r.tfar < 0.0f; // Embree sets tfar = -inf on a hit
                }
                ++c.shadow;
                c.occluded += blocked;
                const double lit = (!blocked && s.nl > 0) ? s.kd * s.nl * LIGHT : 0.0;
                const uint8_t v = srgb8(KA * AMBIENT + lit);
                image[size_t(s.pixel) * 3 + 0] = image[size_t(s.pixel) * 3 + 1] = image[size_t(s.pixel) * 3 + 2] = v;
            }
            const double tc = thread_cpu_s();
            c.camera_cpu += tb - ta;
            c.shadow_cpu += tc - tb;
        }
    };

    // `--repeat N`: the frame N times, the last one reported (a profiler then sees the trace, not
    // the load and build).
    double frame = 0, cpu = 0;
    for (int r = 0; r < o.repeat; ++r) {
        for (Counts &c : counts) c = Counts{};
        next = 0;
        const double cpu0 = process_cpu_s();
        const double f0 = now_s();
        std::vector<std::thread> pool;
        for (int t = 0; t < o.threads; ++t) pool.emplace_back(worker, t);
        for (auto &t : pool) t.join();
        frame = now_s() - f0;
        cpu = process_cpu_s() - cpu0;
    }

    Counts sum;
    for (const Counts &c : counts) {
        sum.camera += c.camera; sum.hits_mesh += c.hits_mesh; sum.hits_plane += c.hits_plane;
        sum.shadow += c.shadow; sum.occluded += c.occluded;
        sum.camera_cpu += c.camera_cpu; sum.shadow_cpu += c.shadow_cpu;
    }
    const double T = o.threads;
    const uint64_t all = sum.camera + sum.shadow;
    std::printf("embree3 %s quality=%s robust=%d threads=%d packet=%d triangles=%zu\n", RTC_VERSION_STRING,
                o.quality == RTC_BUILD_QUALITY_HIGH ? "high" : "medium", int(o.robust), o.threads, o.packet,
                mesh.indices.size() / 3);
    std::printf("load_s %.4f build_s %.4f\n", t1 - t0, t2 - t1);
    std::printf("trace_s %.4f cpu_busy %.2f\n", frame, cpu / (frame * T));
    std::printf("camera_rays %llu hits_mesh %llu hits_plane %llu shadow_rays %llu occluded %llu\n",
                (unsigned long long)sum.camera, (unsigned long long)sum.hits_mesh,
                (unsigned long long)sum.hits_plane, (unsigned long long)sum.shadow,
                (unsigned long long)sum.occluded);
    // Wall-clock rate of the frame (what raylab render's trace time gives), and per-phase rates
    // from the threads' CPU time (what raylab bench reports), as `T` threads running at once.
    std::printf("rays_per_s_wall %.0f\n", all / frame);
    std::printf("camera_rays_per_s_cpu %.0f shadow_rays_per_s_cpu %.0f all_rays_per_s_cpu %.0f\n",
                sum.camera / (sum.camera_cpu / T), sum.shadow / (sum.shadow_cpu / T),
                all / ((sum.camera_cpu + sum.shadow_cpu) / T));
    std::printf("peak_rss_mib %.1f\n", peak_rss_kib() / 1024.0);
    if (!o.ppm.empty()) {
        FILE *f = std::fopen(o.ppm.c_str(), "wb");
        if (!f) die("cannot write " + o.ppm);
        std::fprintf(f, "P6\n%d %d\n255\n", W, H);
        std::fwrite(image.data(), 1, image.size(), f);
        std::fclose(f);
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
    return 0;
}

int load(const Options &o) {
    RTCDevice dev = rtcNewDevice(o.device.empty() ? nullptr : o.device.c_str());
    if (!dev) die("rtcNewDevice failed");
    double t0 = now_s();
    Mesh mesh = read_obj(o.mesh);
    double t1 = now_s();
    RTCScene scene = build_scene(dev, mesh, o);
    double t2 = now_s();
    std::printf("embree3 %s quality=%s robust=%d triangles=%zu vertices=%zu\n", RTC_VERSION_STRING,
                o.quality == RTC_BUILD_QUALITY_HIGH ? "high" : "medium", int(o.robust),
                mesh.indices.size() / 3, mesh.vertex_count());
    std::printf("load_s %.4f build_s %.4f total_s %.4f peak_rss_mib %.1f\n", t1 - t0, t2 - t1, t2 - t0,
                peak_rss_kib() / 1024.0);
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
    return 0;
}

} // namespace

int main(int argc, char **argv) {
    Options o = parse_args(argc, argv);
    return o.mode == "render" ? render(o) : load(o);
}
