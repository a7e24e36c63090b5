// osd_refine: uniform refinement with OpenSubdiv's Far API, the reference for sylva's
// subdivision engine (crates/sylva/src/refine). Reads an OBJ control mesh (v, vt, f with
// any corner form, OpenSubdiv crease tags `t crease 2/1 a b s`, `t corner 1/1 v s`,
// `t interpolateboundary 1/0 n`, `t creasemethod 0/0/1 chaikin`), refines it uniformly
// with Loop or Catmull-Clark and writes the finest level:
//
//   osd_refine IN.obj loop|catmark LEVELS OUT.txt    -> "V F U" header, "v x y z" lines, "vt u v" lines
//   osd_refine IN.obj loop|catmark LEVELS --time N   -> times N runs of create + refine +
//                                                       interpolate positions and UVs (one thread)
//   ... [--fvar none|corners-only|corners-plus1|corners-plus2|boundaries|all]
//
// Options match sylva's defaults: boundary EDGE_AND_CORNER, uniform creasing, face-varying
// FVAR_LINEAR_ALL (sylva --uv linear). `--fvar` picks Sdc::Options::FVarLinearInterpolation
// (FVAR_LINEAR_NONE ... FVAR_LINEAR_ALL) for the UV channel; docs/subdivision.md lists the
// sylva mode that matches each. Build: g++ -O2 -std=c++14 osd_refine.cpp -losdCPU
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace OpenSubdiv;

struct Vec3 {
    float x, y, z;
    void Clear(void * = nullptr) { x = y = z = 0.0f; }
    void AddWithWeight(Vec3 const &s, float w) { x += w * s.x; y += w * s.y; z += w * s.z; }
};
struct Vec2 {
    float u, v;
    void Clear(void * = nullptr) { u = v = 0.0f; }
    void AddWithWeight(Vec2 const &s, float w) { u += w * s.u; v += w * s.v; }
};

struct Obj {
    std::vector<Vec3> positions;
    std::vector<Vec2> uvs;
    std::vector<int> faceSizes, faceVerts, faceUvs;
    std::vector<int> creasePairs, corners;
    std::vector<float> creaseWeights, cornerWeights;
    Sdc::Options::VtxBoundaryInterpolation boundary = Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER;
    Sdc::Options::CreasingMethod creasing = Sdc::Options::CREASE_UNIFORM;
    Sdc::Options::FVarLinearInterpolation fvar = Sdc::Options::FVAR_LINEAR_ALL;
};

static int fail(std::string const &msg) {
    std::fprintf(stderr, "osd_refine: %s\n", msg.c_str());
    return 1;
}

static bool readObj(char const *path, Obj &obj, std::string &err) {
    std::ifstream in(path);
    if (!in) { err = std::string("cannot read ") + path; return false; }
    std::string line;
    int lineNo = 0;
    bool allUv = true;
    while (std::getline(in, line)) {
        ++lineNo;
        std::istringstream ss(line.substr(0, line.find('#')));
        std::string kw;
        if (!(ss >> kw)) continue;
        if (kw == "v") {
            Vec3 p; ss >> p.x >> p.y >> p.z; obj.positions.push_back(p);
        } else if (kw == "vt") {
            Vec2 t{0, 0}; ss >> t.u >> t.v; obj.uvs.push_back(t);
        } else if (kw == "f") {
            std::string c;
            int n = 0;
            while (ss >> c) {
                int v = std::atoi(c.c_str());
                v = v > 0 ? v - 1 : (int)obj.positions.size() + v;
                obj.faceVerts.push_back(v);
                size_t slash = c.find('/');
                if (slash != std::string::npos && slash + 1 < c.size() && c[slash + 1] != '/') {
                    int t = std::atoi(c.c_str() + slash + 1);
                    obj.faceUvs.push_back(t > 0 ? t - 1 : (int)obj.uvs.size() + t);
                } else {
                    allUv = false;
                }
                ++n;
            }
            obj.faceSizes.push_back(n);
        } else if (kw == "t") {
            std::string name, counts;
            ss >> name >> counts;
            int ni = 0, nf = 0, ns = 0;
            std::sscanf(counts.c_str(), "%d/%d/%d", &ni, &nf, &ns);
            std::vector<int> ints(ni);
            std::vector<float> floats(nf);
            std::vector<std::string> strings(ns);
            for (auto &i : ints) ss >> i;
            for (auto &f : floats) ss >> f;
            for (auto &s : strings) ss >> s;
            if (name == "crease") {
                for (int k = 0; k + 1 < ni; k += 2) {
                    obj.creasePairs.push_back(ints[k]);
                    obj.creasePairs.push_back(ints[k + 1]);
                    obj.creaseWeights.push_back(nf > 1 ? floats[k / 2] : floats[0]);
                }
            } else if (name == "corner") {
                for (int k = 0; k < ni; ++k) {
                    obj.corners.push_back(ints[k]);
                    obj.cornerWeights.push_back(nf > 1 ? floats[k] : floats[0]);
                }
            } else if (name == "interpolateboundary" && ni == 1) {
                obj.boundary = ints[0] == 2 ? Sdc::Options::VTX_BOUNDARY_EDGE_ONLY
                                            : Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER;
            } else if (name == "creasemethod" && ns == 1) {
                obj.creasing = strings[0] == "chaikin" ? Sdc::Options::CREASE_CHAIKIN : Sdc::Options::CREASE_UNIFORM;
            }
        }
        if (!ss && !ss.eof()) { err = "bad line " + std::to_string(lineNo); return false; }
    }
    if (!allUv) obj.faceUvs.clear();
    return true;
}

struct Result {
    std::vector<Vec3> positions;  // finest level
    std::vector<Vec2> uvs;        // finest level
    int faces = 0;
};

// Everything sylva's benchmark measures: build the refiner, refine, interpolate.
static bool refine(Obj const &obj, Sdc::SchemeType scheme, int levels, Result &out) {
    typedef Far::TopologyDescriptor Descriptor;
    Sdc::Options options;
    options.SetVtxBoundaryInterpolation(obj.boundary);
    options.SetCreasingMethod(obj.creasing);
    options.SetFVarLinearInterpolation(obj.fvar);

    Descriptor desc;
    desc.numVertices = (int)obj.positions.size();
    desc.numFaces = (int)obj.faceSizes.size();
    desc.numVertsPerFace = obj.faceSizes.data();
    desc.vertIndicesPerFace = obj.faceVerts.data();
    desc.numCreases = (int)obj.creaseWeights.size();
    desc.creaseVertexIndexPairs = obj.creasePairs.data();
    desc.creaseWeights = obj.creaseWeights.data();
    desc.numCorners = (int)obj.corners.size();
    desc.cornerVertexIndices = obj.corners.data();
    desc.cornerWeights = obj.cornerWeights.data();
    Descriptor::FVarChannel channel;
    bool hasUv = !obj.faceUvs.empty();
    if (hasUv) {
        channel.numValues = (int)obj.uvs.size();
        channel.valueIndices = obj.faceUvs.data();
        desc.numFVarChannels = 1;
        desc.fvarChannels = &channel;
    }
    Far::TopologyRefiner *refiner = Far::TopologyRefinerFactory<Descriptor>::Create(
        desc, Far::TopologyRefinerFactory<Descriptor>::Options(scheme, options));
    if (!refiner) return false;
    refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(levels));
    Far::PrimvarRefiner primvar(*refiner);

    std::vector<Vec3> verts(refiner->GetNumVerticesTotal());
    std::copy(obj.positions.begin(), obj.positions.end(), verts.begin());
    Vec3 *src = verts.data();
    for (int l = 1; l <= levels; ++l) {
        Vec3 *dst = src + refiner->GetLevel(l - 1).GetNumVertices();
        primvar.Interpolate(l, src, dst);
        src = dst;
    }
    out.positions.assign(src, src + refiner->GetLevel(levels).GetNumVertices());
    out.uvs.clear();
    if (hasUv) {
        std::vector<Vec2> uvs(refiner->GetNumFVarValuesTotal(0));
        std::copy(obj.uvs.begin(), obj.uvs.end(), uvs.begin());
        Vec2 *s = uvs.data();
        for (int l = 1; l <= levels; ++l) {
            Vec2 *d = s + refiner->GetLevel(l - 1).GetNumFVarValues(0);
            primvar.InterpolateFaceVarying(l, s, d, 0);
            s = d;
        }
        out.uvs.assign(s, s + refiner->GetLevel(levels).GetNumFVarValues(0));
    }
    out.faces = refiner->GetLevel(levels).GetNumFaces();
    delete refiner;
    return true;
}

static bool parseFvar(std::string const &name, Sdc::Options::FVarLinearInterpolation &out) {
    static const struct { char const *name; Sdc::Options::FVarLinearInterpolation value; } modes[] = {
        {"none", Sdc::Options::FVAR_LINEAR_NONE},
        {"corners-only", Sdc::Options::FVAR_LINEAR_CORNERS_ONLY},
        {"corners-plus1", Sdc::Options::FVAR_LINEAR_CORNERS_PLUS1},
        {"corners-plus2", Sdc::Options::FVAR_LINEAR_CORNERS_PLUS2},
        {"boundaries", Sdc::Options::FVAR_LINEAR_BOUNDARIES},
        {"all", Sdc::Options::FVAR_LINEAR_ALL},
    };
    for (auto const &m : modes) {
        if (name == m.name) { out = m.value; return true; }
    }
    return false;
}

int main(int argc, char **argv) {
    // Take `--fvar MODE` out of the arguments, wherever it is.
    Sdc::Options::FVarLinearInterpolation fvar = Sdc::Options::FVAR_LINEAR_ALL;
    std::vector<char *> args(argv, argv + argc);
    for (size_t i = 1; i < args.size(); ++i) {
        if (std::string(args[i]) == "--fvar") {
            if (i + 1 >= args.size() || !parseFvar(args[i + 1], fvar)) {
                return fail("--fvar needs none|corners-only|corners-plus1|corners-plus2|boundaries|all");
            }
            args.erase(args.begin() + i, args.begin() + i + 2);
            break;
        }
    }
    argc = (int)args.size();
    argv = args.data();
    if (argc != 5 && argc != 6) {
        return fail("usage: osd_refine IN.obj loop|catmark LEVELS (OUT.txt | --time N) [--fvar MODE]");
    }
    Obj obj;
    std::string err;
    if (!readObj(argv[1], obj, err)) return fail(err);
    obj.fvar = fvar;
    std::string s = argv[2];
    if (s != "loop" && s != "catmark") return fail("scheme must be loop or catmark");
    Sdc::SchemeType scheme = s == "loop" ? Sdc::SCHEME_LOOP : Sdc::SCHEME_CATMARK;
    int levels = std::atoi(argv[3]);
    Result r;
    if (std::string(argv[4]) == "--time") {
        int runs = argc == 6 ? std::max(1, std::atoi(argv[5])) : 10;
        std::vector<double> ms;
        for (int i = 0; i < runs; ++i) {
            auto t0 = std::chrono::steady_clock::now();
            if (!refine(obj, scheme, levels, r)) return fail("refinement failed");
            auto t1 = std::chrono::steady_clock::now();
            ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        }
        std::sort(ms.begin(), ms.end());
        double med = ms[ms.size() / 2];
        std::printf("faces %d median_ms %.3f min_ms %.3f mfaces_per_s %.3f\n", r.faces, med, ms[0],
                    r.faces / med / 1e3);
        return 0;
    }
    if (!refine(obj, scheme, levels, r)) return fail("refinement failed (invalid topology?)");
    FILE *out = std::fopen(argv[4], "w");
    if (!out) return fail(std::string("cannot write ") + argv[4]);
    std::fprintf(out, "%zu %d %zu\n", r.positions.size(), r.faces, r.uvs.size());
    for (auto const &p : r.positions) std::fprintf(out, "v %.9g %.9g %.9g\n", p.x, p.y, p.z);
    for (auto const &t : r.uvs) std::fprintf(out, "vt %.9g %.9g\n", t.u, t.v);
    std::fclose(out);
    return 0;
}
