// Chapter 17's building blocks in OpenCL C 1.2: what the stages (stages.cl) call at one path's vertex. Each is the
// C++ library's function of the same name (common/), written again in float for a device: the random numbers
// (core/rng.h), the azimuth (core/math.h sinCos2Pi), the shading frame (core/frame.h), ray–sphere and ray–triangle
// intersection with their error bounds (geometry/sphere.h, triangle.h), the box test and the walk of chapter 9's
// eight-wide tree (geometry/bvh.h), the BSDFs (shading/bsdf.cpp) and light sampling (scene/light_sampling.h).
// No recursion, no function pointers, no double unless the device has it: any OpenCL 1.2 driver builds this.

#define kPi 3.14159265358979f
#define kInvPi 0.318309886183791f
#define kRouletteMinBounces 3
#define kRouletteMaxSurvival 0.95f
#define kShadowRayShorten 1e-4f
#define kMinPhongRoughness 1e-3f
#define kMinGgxAlpha 1e-3f
#define kMaxPhongExponent (2.0f / (kMinPhongRoughness * kMinPhongRoughness) - 2.0f)

// Material types, as MaterialType numbers them.
#define kDiffuse 0
#define kMirror 1
#define kGlass 2
#define kGlossy 3
#define kMetal 4
#define kInterface 5

// γ(n) = n·u / (1 − n·u) for float (u = 2⁻²⁴): the bound on n chained roundings.
float gammaF(int n)
{
  const float u = 5.9604645e-8f;
  return (float)n * u / (1.0f - (float)n * u);
}

// ---- Random numbers keyed by (seed, pixel, sample): core/rng.h ------------------------------------------------

ulong mix64(ulong z)
{
  z += 0x9e3779b97f4a7c15UL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9UL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebUL;
  return z ^ (z >> 31);
}

// PCG32 (XSH RR): a path's whole random state is these two words.
typedef struct {
  ulong state;
  ulong inc;
} Rng;

uint rngNext(Rng* r)
{
  const ulong old = r->state;
  r->state = old * 6364136223846793005UL + r->inc;
  const uint xorshifted = (uint)(((old >> 18) ^ old) >> 27);
  const uint rot = (uint)(old >> 59);
  return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

// Sampler(seed, x, y, sample): the same seeding as the CPU's.
Rng samplerMake(ulong seed, int x, int y, ulong sample)
{
  const ulong key = mix64(seed ^ mix64((ulong)(uint)x | ((ulong)(uint)y << 32)));
  const ulong stream = mix64(sample ^ 0x5851f42d4c957f2dUL);
  Rng r;
  r.state = 0;
  r.inc = (stream << 1) | 1UL;
  rngNext(&r);
  r.state += key;
  rngNext(&r);
  return r;
}

// Uniform in [0, 1): 24 random bits, as Sampler::next1D in float.
float next1D(Rng* r) { return (float)(rngNext(r) >> 8) * 5.9604645e-8f; }

// ---- PixelSequence (core/rng.h): scrambled Sobol points for sample counts not known in advance ------------------

uint reverseBits(uint x)
{
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
  return (x >> 16) | (x << 16);
}

uint sobolSecondReversed(uint index)
{
  index ^= (index >> 1) & 0x55555555u;
  index ^= (index >> 2) & 0x33333333u;
  index ^= (index >> 4) & 0x0f0f0f0fu;
  index ^= (index >> 8) & 0x00ff00ffu;
  index ^= (index >> 16) & 0x0000ffffu;
  return index;
}

uint scrambleReversed(uint x, uint seed)
{
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

float2 pixelSequencePoint(ulong seed, int x, int y, uint index)
{
  const ulong h = mix64(seed ^ mix64((ulong)(uint)x | ((ulong)(uint)y << 32)) ^ 0x2545f4914f6cdd1dUL);
  const uint sx = (uint)h, sy = (uint)(h >> 32);
  return (float2)((float)(reverseBits(scrambleReversed(index, sx)) >> 8) * 5.9604645e-8f,
                  (float)(reverseBits(scrambleReversed(sobolSecondReversed(index), sy)) >> 8) * 5.9604645e-8f);
}

// ---- sin and cos of 2πu (core/math.h sinCos2Pi, float polynomials): exact at the quarter turns -----------------

float2 sinCos2Pi(float u) // (sin, cos)
{
  const int octant = (int)(u * 8.0f);
  const int quarter = (octant + 1) >> 1;
  const float f = u * 4.0f - (float)quarter;
  const float w = f * f;
  const float s = f * (1.57079632f + w * (-6.45963478e-1f + w * (7.96802176e-2f + w * -4.60214921e-3f)));
  const float c = 1.0f - w * (1.23370055f + w * (-2.5366941e-1f + w * (2.08615283e-2f + w * -9.06739898e-4f)));
  const float quarterCos[4] = {1.0f, 0.0f, -1.0f, 0.0f};
  const float a = quarterCos[quarter & 3];
  const float b = quarterCos[(quarter + 3) & 3];
  return (float2)(a * s + b * c, a * c - b * s);
}

// ---- The shading frame (core/frame.h) ---------------------------------------------------------------------------

typedef struct {
  float3 s, t, n;
} Frame;

Frame frameFromNormal(float3 n)
{
  const float sign = copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float b = n.x * n.y * a;
  Frame f;
  f.s = (float3)(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
  f.t = (float3)(b, sign + n.y * n.y * a, -n.y);
  f.n = n;
  return f;
}
float3 toLocal(const Frame* f, float3 w) { return (float3)(dot(w, f->s), dot(w, f->t), dot(w, f->n)); }
float3 toWorld(const Frame* f, float3 l) { return l.x * f->s + l.y * f->t + l.z * f->n; }

// The unit vector along v, or `fallback` when v has no direction (core/math.h safeNormalize).
float3 safeNormalize(float3 v, float3 fallback)
{
  const float l = length(v);
  return l > 0.0f && isfinite(l) ? v / l : fallback;
}

// ---- Samplers (core/sampling.h) ---------------------------------------------------------------------------------

float3 sampleCosineHemisphere(float2 u)
{
  const float r = sqrt(u.x);
  const float2 phi = sinCos2Pi(u.y);
  return (float3)(r * phi.y, r * phi.x, sqrt(fmax(0.0f, 1.0f - u.x)));
}

float3 samplePhongLobe(float2 u, float exponent)
{
  const float cosAlpha = pow(1.0f - u.x, 1.0f / (exponent + 1.0f));
  const float sinAlpha = sqrt(fmax(0.0f, 1.0f - cosAlpha * cosAlpha));
  const float2 phi = sinCos2Pi(u.y);
  return (float3)(sinAlpha * phi.y, sinAlpha * phi.x, cosAlpha);
}

float phongLobePdf(float cosAlpha, float exponent)
{
  return cosAlpha > 0.0f ? (exponent + 1.0f) / (2.0f * kPi) * pow(cosAlpha, exponent) : 0.0f;
}

// ---- Ray–sphere (geometry/sphere.h): the robust quadratic of Ray Tracing Gems ch. 7 -------------------------------

// The nearest root in [tmin, tmax), or −1 when there is none.
float intersectSphere(float3 o, float3 d, float3 c, float r, float tmin, float tmax)
{
  // (The sums written out, in the order intersectSpheres' lanes add them, so that the two give the same bits.)
  const float3 f = o - c;
  const float ff = f.x * f.x + f.y * f.y + f.z * f.z, rr = r * r;
  const float b = -(f.x * d.x + f.y * d.y + f.z * d.z);
  if (ff > rr && b <= 0.0f)
    return -1.0f; // outside, heading away
  if (ff < rr && b >= tmax)
    return -1.0f; // inside, the root ahead beyond tmax
  const float3 l = f + b * d;
  const float disc = rr - (l.x * l.x + l.y * l.y + l.z * l.z);
  if (disc < 0.0f)
    return -1.0f;
  const float q = b + copysign(sqrt(disc), b);
  float t0 = b, t1 = b;
  if (q != 0.0f) {
    t0 = (ff - rr) / q;
    t1 = q;
    if (t0 > t1) {
      const float s = t0;
      t0 = t1;
      t1 = s;
    }
  }
  if (t0 >= tmin && t0 < tmax)
    return t0;
  if (t1 >= tmin && t1 < tmax)
    return t1;
  return -1.0f;
}

// The same test against eight spheres at once, one a lane of a float8 (centres cx, cy, cz, radii r): each lane's
// nearest root in [tmin, tmax), or −1, by intersectSphere's arithmetic in the same order, its early returns made
// masks, so the same bits. For CPU devices (SPHERE_LANES), where each float8 operation is one vector instruction.
float8 intersectSpheres(float3 o, float3 d, float8 cx, float8 cy, float8 cz, float8 r, float tmin, float tmax)
{
  const float8 fx = o.x - cx, fy = o.y - cy, fz = o.z - cz;
  const float8 ff = fx * fx + fy * fy + fz * fz, rr = r * r;
  const float8 b = -(fx * d.x + fy * d.y + fz * d.z);
  const int8 none = (ff > rr && b <= 0.0f) || (ff < rr && b >= tmax); // heading away; the root ahead beyond tmax
  const float8 lx = fx + b * d.x, ly = fy + b * d.y, lz = fz + b * d.z;
  const float8 disc = rr - (lx * lx + ly * ly + lz * lz);
  const float8 q = b + copysign(sqrt(disc), b);
  const int8 qZero = q == 0.0f;
  const float8 t0 = select((ff - rr) / q, b, qZero), t1 = select(q, b, qZero);
  const int8 swap = t0 > t1;
  const float8 near = select(t0, t1, swap), far = select(t1, t0, swap);
  const float8 t = select(select((float8)(-1.0f), far, far >= tmin && far < tmax), near, near >= tmin && near < tmax);
  return select(t, (float8)(-1.0f), none || disc < 0.0f);
}

// A surface point with its error bound: the hit re-projected onto the sphere (sphereSurfacePoint).
typedef struct {
  float3 point, normal, error;
} SurfacePoint;

SurfacePoint sphereSurfacePoint(float3 o, float3 d, float t, float3 c, float r)
{
  const float3 fromCentre = (o + t * d) - c;
  const float len = length(fromCentre);
  SurfacePoint sp;
  sp.normal = len > 0.0f ? fromCentre / len : (float3)(0.0f, 0.0f, 1.0f);
  const float3 onSphere = sp.normal * r;
  sp.point = c + onSphere;
  sp.error = gammaF(5) * fabs(onSphere) + gammaF(2) * fabs(sp.point);
  return sp;
}

// The origin moved off the surface by its error bound to the side w leaves through, one ulp further
// (offsetRayOrigin): a new ray starts there with tmin = 0.
float nextAlong(float v, float direction)
{
  return direction > 0.0f ? nextafter(v, INFINITY) : direction < 0.0f ? nextafter(v, -INFINITY) : v;
}
float3 offsetRayOrigin(float3 p, float3 error, float3 n, float3 w)
{
  const float distance = dot(fabs(n), error);
  const float3 offset = (dot(w, n) < 0.0f ? -distance : distance) * n;
  const float3 po = p + offset;
  return (float3)(nextAlong(po.x, offset.x), nextAlong(po.y, offset.y), nextAlong(po.z, offset.z));
}

// ---- Ray–triangle (geometry/triangle.h): the watertight test of Woop, Benthin and Wald ---------------------------

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

float component(float3 v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
float3 permute(float3 v, int kx, int ky, int kz) { return (float3)(component(v, kx), component(v, ky), component(v, kz)); }

// t and the barycentrics (b0, b1, b2) where the ray meets the triangle in [tmin, tmax); t = −1: no hit.
float4 intersectTriangle(float3 o, float3 d, float3 p0, float3 p1, float3 p2, float tmin, float tmax)
{
  const float4 miss = (float4)(-1.0f, 0.0f, 0.0f, 0.0f);
  const float3 ad = fabs(d);
  const int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  const int kx = kz == 2 ? 0 : kz + 1;
  const int ky = kx == 2 ? 0 : kx + 1;
  const float3 dp = permute(d, kx, ky, kz);
  float3 a = permute(p0 - o, kx, ky, kz), b = permute(p1 - o, kx, ky, kz), c = permute(p2 - o, kx, ky, kz);
  const float sx = -dp.x / dp.z, sy = -dp.y / dp.z, sz = 1.0f / dp.z;
  a.x += sx * a.z;
  a.y += sy * a.z;
  b.x += sx * b.z;
  b.y += sy * b.z;
  c.x += sx * c.z;
  c.y += sy * c.z;
  float e0 = b.x * c.y - b.y * c.x;
  float e1 = c.x * a.y - c.y * a.x;
  float e2 = a.x * b.y - a.y * b.x;
#ifdef cl_khr_fp64
  if (e0 == 0.0f || e1 == 0.0f || e2 == 0.0f) { // rounding's zero? decide again in double (as Woop et al.)
    e0 = (float)((double)b.x * (double)c.y - (double)b.y * (double)c.x);
    e1 = (float)((double)c.x * (double)a.y - (double)c.y * (double)a.x);
    e2 = (float)((double)a.x * (double)b.y - (double)a.y * (double)b.x);
  }
#endif
  if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f))
    return miss;
  const float det = e0 + e1 + e2;
  if (det == 0.0f)
    return miss;
  a.z *= sz;
  b.z *= sz;
  c.z *= sz;
  const float tScaled = e0 * a.z + e1 * b.z + e2 * c.z;
  if ((det < 0.0f && tScaled >= 0.0f) || (det > 0.0f && tScaled <= 0.0f))
    return miss;
  const float invDet = 1.0f / det;
  const float t = tScaled * invDet;
  if (!(t >= tmin && t < tmax))
    return miss;
  // t must be greater than 0 beyond its rounding error (pbrt-v4's bound).
  const float maxZ = fmax(fabs(a.z), fmax(fabs(b.z), fabs(c.z)));
  const float maxX = fmax(fabs(a.x), fmax(fabs(b.x), fabs(c.x)));
  const float maxY = fmax(fabs(a.y), fmax(fabs(b.y), fabs(c.y)));
  const float deltaZ = gammaF(3) * maxZ;
  const float deltaX = gammaF(5) * (maxX + maxZ);
  const float deltaY = gammaF(5) * (maxY + maxZ);
  const float deltaE = 2.0f * (gammaF(2) * maxX * maxY + deltaY * maxX + deltaX * maxY);
  const float maxE = fmax(fabs(e0), fmax(fabs(e1), fabs(e2)));
  const float deltaT = 3.0f * (gammaF(3) * maxE * maxZ + deltaE * maxZ + deltaZ * maxE) * fabs(invDet);
  if (!(t > deltaT))
    return miss;
  return (float4)(t, e0 * invDet, e1 * invDet, e2 * invDet);
}

float3 triangleNormal(float3 p0, float3 p1, float3 p2)
{
  return safeNormalize(cross(p1 - p0, p2 - p0), (float3)(0.0f, 0.0f, 1.0f));
}

// ---- The scene as the host flattened it ---------------------------------------------------------------------------

// One node of chapter 9's eight-wide tree, byte for byte as BvhWideNode: the children's boxes by coordinate, then
// the children (kLeaf | first primitive of a leaf, with kTriangles for triangles; else a node's index).
typedef struct {
  float bounds[48];
  uint child[8];
  uint boxes;
  uint pad[7];
} WideNode;

#define kLeaf 0x80000000u
#define kTriangles 0x40000000u
#define kIndexMask 0x3fffffffu
#define kLastInLeaf 0x80000000u
// The walk's stack: a node popped pushes at most 8 children, so the stack grows by at most 7 a level, and the tree is
// at most 64 levels deep (Bvh::kMaxDepth; the host checks it): 1 + 7·64 entries are always enough.
#define kStackSize 449

// Everything a query reads of the scene; made once per kernel from its arguments.
typedef struct {
  __global const float4* spheres;    // centre, radius
  __global const int* sphereMaterials;
  __global const float4* vertices;   // xyz
  __global const uint4* triangles;   // corners' indices, material
  __global const WideNode* nodes;    // the tree (none: a flat list)
  __global const uint* leafSpheres;  // the tree's sphere lists: primitive | kLastInLeaf
  __global const uint* leafTriangles;
  __global const int* outside;       // primitives kept out of the tree, tested first
  int sphereCount, triangleCount, nodeCount, outsideCount;
} Geometry;

float3 vertexAt(const Geometry* g, uint i) { return g->vertices[i].xyz; }
int materialOf(const Geometry* g, int p)
{
  return p < g->sphereCount ? g->sphereMaterials[p] : (int)g->triangles[p - g->sphereCount].w;
}

// The box test for child k of a node: whether the ray's interval [tmin, tmax) meets its box, and where it enters
// (INFINITY: it misses). Float throughout; the interval is widened by the BVH's margin (kBoxMargin) and a few
// roundings, so that a box the exact ray touches is never culled. An origin exactly on a face (0·∞ = NaN) keeps
// the box.
float boxEntry(__global const WideNode* node, int k, float3 o, float3 inv, float tmin, float tmax)
{
  const float widen = gammaF(32) + gammaF(8);
  __global const float* b = node->bounds;
  const float3 lo = (float3)(b[k], b[8 + k], b[16 + k]), hi = (float3)(b[24 + k], b[32 + k], b[40 + k]);
  float3 t0 = (lo - o) * inv, t1 = (hi - o) * inv;
  const int3 undefined = isnan(t0) | isnan(t1); // 0·∞: the origin on a face, the ray along it
  t0 = select(t0, (float3)(-INFINITY), undefined);
  t1 = select(t1, (float3)(INFINITY), undefined);
  const float3 near = fmin(t0, t1) * (1.0f - widen), far = fmax(t0, t1) * (1.0f + widen);
  const float tNear = fmax(tmin, fmax(near.x, fmax(near.y, near.z)));
  const float tFar = fmin(tmax, fmin(far.x, fmin(far.y, far.z)));
  return tNear <= tFar ? tNear : INFINITY;
}

// One axis of the box test below, for a node's eight children: where the ray enters each child's slab (returned)
// and where it leaves it (*far), widened.
float8 slab(__global const float* bounds, int axis, float o, float inv, float widen, float8* far)
{
  float8 t0 = (vload8(axis, bounds) - o) * inv, t1 = (vload8(3 + axis, bounds) - o) * inv;
  const int8 undefined = isnan(t0) | isnan(t1); // 0·∞: the origin on a face, the ray along it
  t0 = select(t0, (float8)(-INFINITY), undefined);
  t1 = select(t1, (float8)(INFINITY), undefined);
  *far = fmax(t0, t1) * (1.0f + widen);
  return fmin(t0, t1) * (1.0f - widen);
}

// The same test for all eight children of a node at once, one child a lane of a float8 (the bounds lie by
// coordinate, eight to a row, so each row is one vload8), the same arithmetic lane by lane: boxEntry(node, k, ...)
// in lane k, and INFINITY where the node has no child k. On a CPU device each float8 operation is one vector
// instruction, as chapter 9's walk tests its boxes; a GPU's work-item would do all eight lanes one after another,
// empty slots too, so the walk uses it on CPU devices only (BOX_LANES).
float8 boxEntries(__global const WideNode* node, float3 o, float3 inv, float tmin, float tmax)
{
  const float widen = gammaF(32) + gammaF(8);
  float8 farX, farY, farZ;
  const float8 nearX = slab(node->bounds, 0, o.x, inv.x, widen, &farX);
  const float8 nearY = slab(node->bounds, 1, o.y, inv.y, widen, &farY);
  const float8 nearZ = slab(node->bounds, 2, o.z, inv.z, widen, &farZ);
  const float8 tNear = fmax(fmax(nearX, fmax(nearY, nearZ)), tmin);
  const float8 tFar = fmin(fmin(farX, fmin(farY, farZ)), tmax);
  const int8 child = (int8)(0, 1, 2, 3, 4, 5, 6, 7);
  return select((float8)(INFINITY), tNear, tNear <= tFar && child < (int8)((int)node->boxes));
}

// Primitive `p` against the ray: t, or −1.
float intersectPrimitive(const Geometry* g, int p, float3 o, float3 d, float tmin, float tmax)
{
  if (p < g->sphereCount) {
    const float4 s = g->spheres[p];
    return intersectSphere(o, d, s.xyz, s.w, tmin, tmax);
  }
  const uint4 tri = g->triangles[p - g->sphereCount];
  return intersectTriangle(o, d, vertexAt(g, tri.x), vertexAt(g, tri.y), vertexAt(g, tri.z), tmin, tmax).x;
}

// The nearest hit in [0, tmax) (anyHit: any hit) — the primitives outside the tree, then the tree front to back
// with an explicit stack (no recursion on a device), or the flat list. Returns (t, primitive); primitive −1: none.
float2 traceRay(const Geometry* g, float3 o, float3 d, float tmax, int anyHit)
{
  float best = tmax;
  int found = -1;
  if (g->nodeCount == 0) {
    const int count = g->sphereCount + g->triangleCount;
    int p = 0;
#if SPHERE_LANES // (a CPU device: the spheres eight at a time, one a lane; the host pads their list to a multiple of 8)
    for (; p < g->sphereCount; p += 8) {
      __global const float* s = (__global const float*)(g->spheres + p);
      const float16 a = vload16(0, s), b = vload16(1, s); // spheres p to p + 3, p + 4 to p + 7: centre, radius
      float t[8];
      vstore8(intersectSpheres(o, d, (float8)(a.s048c, b.s048c), (float8)(a.s159d, b.s159d),
                               (float8)(a.s26ae, b.s26ae), (float8)(a.s37bf, b.s37bf), 0.0f, best),
              0, t);
      // In order, as the loop below takes them: a root below the nearest so far, the first of equal ones. (The
      // lanes' roots are intersectSphere's bit for bit, tests/opencl checks: a shadow ray must stop exactly where
      // light sampling's intersectSphere put its end, on the light's own sphere.)
      for (int k = 0; k < 8 && p + k < g->sphereCount; ++k)
        if (t[k] >= 0.0f && t[k] < best) {
          best = t[k];
          found = p + k;
          if (anyHit)
            return (float2)(best, as_float(found));
        }
    }
    p = g->sphereCount;
#endif
    for (; p < count; ++p) {
      const float t = intersectPrimitive(g, p, o, d, 0.0f, best);
      if (t >= 0.0f) {
        best = t;
        found = p;
        if (anyHit)
          break;
      }
    }
    return (float2)(best, as_float(found));
  }
  for (int i = 0; i < g->outsideCount; ++i) {
    const int p = g->outside[i];
    const float t = intersectPrimitive(g, p, o, d, 0.0f, best);
    if (t >= 0.0f) {
      best = t;
      found = p;
      if (anyHit)
        return (float2)(best, as_float(found));
    }
  }
  const float3 inv = 1.0f / d;
  uint stack[kStackSize];
  float entry[kStackSize];
  int top = 0;
  stack[top] = 0;
  entry[top++] = 0.0f;
  while (top > 0) {
    --top;
    if (entry[top] >= best)
      continue; // found something nearer since this was pushed
    const uint item = stack[top];
    if (item & kLeaf) {
      // A leaf: its primitives lie side by side in their kind's list, the last one marked (triangles four to a
      // pack: the child holds the leaf's first pack, Bvh::leafPrimitives).
      const int triangles = (item & kTriangles) != 0;
      for (uint i = triangles ? 4 * (item & kIndexMask) : item & kIndexMask;; ++i) {
        const uint e = triangles ? g->leafTriangles[i] : g->leafSpheres[i];
        const int p = (int)(e & ~kLastInLeaf);
        const float t = intersectPrimitive(g, p, o, d, 0.0f, best);
        if (t >= 0.0f && (t < best || (t == best && p < found))) {
          best = t;
          found = p;
          if (anyHit)
            return (float2)(best, as_float(found));
        }
        if (e & kLastInLeaf)
          break;
      }
      continue;
    }
    // A node: the children the ray enters, pushed farthest first so that the nearest comes off the stack next.
    __global const WideNode* node = &g->nodes[item];
#if BOX_LANES // (a CPU device: the host says so)
    float entries[8];
    vstore8(boxEntries(node, o, inv, 0.0f, best), 0, entries);
#endif
    const int boxes = (int)node->boxes;
    const int base = top;
    for (int k = 0; k < boxes; ++k) {
#if BOX_LANES
      const float t = entries[k];
#else
      const float t = boxEntry(node, k, o, inv, 0.0f, best);
#endif
      if (t == INFINITY)
        continue;
      int at = top++;
      while (at > base && entry[at - 1] < t) {
        stack[at] = stack[at - 1];
        entry[at] = entry[at - 1];
        --at;
      }
      stack[at] = node->child[k];
      entry[at] = t;
    }
  }
  return (float2)(best, as_float(found));
}

// ---- The environment map (shading/environment.cpp): the texel under a direction ---------------------------------

// What a ray that leaves the scene along unit direction d sees: the background, or, where info's width (x) is not 0,
// the environment map's texel under d (EnvironmentMap::radiance: d turned back by the map's turn, sine info.z and
// cosine info.w, then u = ½ + atan2(x, −z)/2π and v = acos(y)/π, nearest texel). `texels`: width × height, row 0
// first, scale applied.
float3 escapedRadiance(__global const float4* texels, float4 info, float3 background, float3 d)
{
  if (info.x == 0.0f)
    return background;
  const float sinTurn = -info.z, cosTurn = info.w; // (turned back: rotateAboutY by the opposite angle)
  const float3 r = (float3)(d.x * cosTurn + d.z * sinTurn, d.y, -d.x * sinTurn + d.z * cosTurn);
  const float u = clamp(0.5f + atan2(r.x, -r.z) / (2.0f * kPi), 0.0f, 1.0f);
  const float v = acos(clamp(r.y, -1.0f, 1.0f)) / kPi;
  const int w = (int)info.x, h = (int)info.y;
  const int i = clamp((int)(u * info.x), 0, w - 1), j = clamp((int)(v * info.y), 0, h - 1);
  return texels[j * w + i].xyz;
}

// ---- BSDFs (shading/bsdf.cpp), in the local frame where cosθ = w.z ----------------------------------------------

// A material as the host packs it: colour and type, emission and ior, roughness.
typedef struct {
  float3 color, emission;
  float ior, roughness;
  int type;
} Material;

Material materialAt(__global const float4* materials, int m)
{
  Material r;
  const float4 a = materials[3 * m], b = materials[3 * m + 1], c = materials[3 * m + 2];
  r.color = a.xyz;
  r.type = (int)a.w;
  r.emission = b.xyz;
  r.ior = b.w;
  r.roughness = c.x;
  return r;
}

int isEmissive(const Material* m) { return m->emission.x > 0.0f || m->emission.y > 0.0f || m->emission.z > 0.0f; }

// A BSDF sample: direction, f, pdf (> 0 when there is one), and whether the lobe is a Dirac delta.
typedef struct {
  float3 wi, f;
  float pdf;
  int specular;
} BsdfSample;

float3 reflectLocal(float3 w) { return (float3)(-w.x, -w.y, w.z); }
int sameSide(float3 wo, float3 wi) { return wo.z * wi.z > 0.0f; }

float fresnelDielectric(float cosThetaO, float eta)
{
  float cosI = clamp(cosThetaO, -1.0f, 1.0f);
  if (cosI < 0.0f) {
    eta = 1.0f / eta;
    cosI = -cosI;
  }
  const float cos2T = ((eta - 1.0f) * (eta + 1.0f) + cosI * cosI) / (eta * eta);
  if (cos2T <= 0.0f)
    return 1.0f;
  const float cosT = sqrt(cos2T);
  const float rPar = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rPerp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return (rPar * rPar + rPerp * rPerp) / 2.0f;
}

float phongExponent(float roughness) { return 2.0f / (roughness * roughness) - 2.0f; }

float3 schlickFresnel(float3 f0, float cosTheta)
{
  const float m = clamp(1.0f - cosTheta, 0.0f, 1.0f);
  const float m2 = m * m;
  return f0 + (1.0f - f0) * (m2 * m2 * m);
}

float ggxD(float3 h, float alpha)
{
  if (h.z <= 0.0f)
    return 0.0f;
  const float a2 = alpha * alpha;
  const float den = (a2 - 1.0f) * (h.z * h.z) + 1.0f;
  return a2 / (kPi * den * den);
}

float ggxLambda(float3 w, float alpha)
{
  const float cos2 = w.z * w.z;
  if (cos2 == 0.0f)
    return INFINITY;
  const float a2Tan2 = alpha * alpha * fmax(0.0f, 1.0f - cos2) / cos2;
  return (sqrt(1.0f + a2Tan2) - 1.0f) / 2.0f;
}

float3 sampleGgxVisibleNormal(float3 wo, float alpha, float2 u)
{
  const float3 v = normalize((float3)(alpha * wo.x, alpha * wo.y, wo.z));
  const float lengthSq = v.x * v.x + v.y * v.y;
  const float3 t1 = lengthSq > 0.0f ? (float3)(-v.y, v.x, 0.0f) / sqrt(lengthSq) : (float3)(1.0f, 0.0f, 0.0f);
  const float3 t2 = cross(v, t1);
  const float r = sqrt(u.x);
  const float2 phi = sinCos2Pi(u.y);
  const float p1 = r * phi.y;
  const float s = (1.0f + v.z) / 2.0f;
  const float p2 = (1.0f - s) * sqrt(fmax(0.0f, 1.0f - p1 * p1)) + s * r * phi.x;
  const float3 n = p1 * t1 + p2 * t2 + sqrt(fmax(0.0f, 1.0f - p1 * p1 - p2 * p2)) * v;
  return normalize((float3)(alpha * n.x, alpha * n.y, fmax(0.0f, n.z)));
}

float3 upper(float3 w, int flip) { return flip ? (float3)(w.x, w.y, -w.z) : w; }

float3 bsdfEval(const Material* m, float3 wo, float3 wi)
{
  if (!sameSide(wo, wi))
    return (float3)(0.0f);
  if (m->type == kDiffuse)
    return m->color * kInvPi;
  if (m->type == kGlossy) {
    const float n = phongExponent(m->roughness);
    const float cosAlpha = dot(wi, reflectLocal(wo));
    if (!(n <= kMaxPhongExponent) || cosAlpha <= 0.0f)
      return (float3)(0.0f);
    return m->color * ((n + 2.0f) / (2.0f * kPi) * pow(cosAlpha, n));
  }
  if (m->type == kMetal && m->roughness >= kMinGgxAlpha) {
    const int flip = wo.z < 0.0f;
    const float3 o = upper(wo, flip), i = upper(wi, flip);
    const float3 h = normalize(o + i);
    const float G2 = 1.0f / (1.0f + ggxLambda(o, m->roughness) + ggxLambda(i, m->roughness));
    return ggxD(h, m->roughness) * G2 * schlickFresnel(m->color, fabs(dot(i, h))) / (4.0f * o.z * i.z);
  }
  return (float3)(0.0f); // mirror, glass, smooth metal: delta lobes, which no other direction finds
}

float bsdfPdf(const Material* m, float3 wo, float3 wi)
{
  if (!sameSide(wo, wi))
    return 0.0f;
  if (m->type == kDiffuse)
    return fabs(wi.z) * kInvPi;
  if (m->type == kGlossy) {
    const float n = phongExponent(m->roughness);
    return n <= kMaxPhongExponent ? phongLobePdf(dot(wi, reflectLocal(wo)), n) : 0.0f;
  }
  if (m->type == kMetal && m->roughness >= kMinGgxAlpha) {
    const int flip = wo.z < 0.0f;
    const float3 o = upper(wo, flip), i = upper(wi, flip);
    const float3 h = normalize(o + i);
    return ggxD(h, m->roughness) / (1.0f + ggxLambda(o, m->roughness)) / (4.0f * o.z);
  }
  return 0.0f;
}

// bsdfSample: pdf 0 when there is no sample.
BsdfSample bsdfSample(const Material* m, float3 wo, float2 u, float uChoice)
{
  BsdfSample bs;
  bs.wi = (float3)(0.0f, 0.0f, 1.0f);
  bs.f = (float3)(0.0f);
  bs.pdf = 0.0f;
  bs.specular = 0;
  if (wo.z == 0.0f)
    return bs;
  const float3 r = reflectLocal(wo);
  if (m->type == kInterface) { // (an invisible boundary: the ray goes on unchanged, passThroughSample)
    bs.wi = -wo;
    bs.f = (float3)(1.0f / fabs(wo.z));
    bs.pdf = 1.0f;
    bs.specular = 1;
    return bs;
  }
  if (m->type == kDiffuse) {
    float3 wi = sampleCosineHemisphere(u);
    if (wo.z < 0.0f)
      wi.z = -wi.z;
    bs.wi = wi;
    bs.f = m->color * kInvPi;
    bs.pdf = sameSide(wo, wi) ? fabs(wi.z) * kInvPi : 0.0f;
    return bs;
  }
  if (m->type == kMirror) {
    bs.wi = r;
    bs.f = m->color / fabs(r.z);
    bs.pdf = 1.0f;
    bs.specular = 1;
    return bs;
  }
  if (m->type == kGlass) {
    const float F = fresnelDielectric(wo.z, m->ior);
    bs.specular = 1;
    if (uChoice < F) {
      bs.wi = r;
      bs.f = m->color * F / fabs(r.z);
      bs.pdf = F;
      return bs;
    }
    // Refraction (bsdf.cpp refract with the local normal (0, 0, 1)).
    float eta = m->ior, cosI = wo.z;
    float3 nFacing = (float3)(0.0f, 0.0f, 1.0f);
    if (cosI < 0.0f) {
      eta = 1.0f / eta;
      cosI = -cosI;
      nFacing = -nFacing;
    }
    const float cos2T = ((eta - 1.0f) * (eta + 1.0f) + cosI * cosI) / (eta * eta);
    if (cos2T <= 0.0f)
      return bs;
    const float3 wi = normalize(-wo / eta + (cosI / eta - sqrt(cos2T)) * nFacing);
    if (wi.z == 0.0f)
      return bs;
    bs.wi = wi;
    bs.f = m->color * (1.0f - F) / fabs(wi.z);
    bs.pdf = 1.0f - F;
    return bs;
  }
  if (m->type == kGlossy) {
    const float n = phongExponent(m->roughness);
    if (!(n <= kMaxPhongExponent)) { // smooth: the mirror the lobe narrows to
      bs.wi = r;
      bs.f = m->color / fabs(r.z);
      bs.pdf = 1.0f;
      bs.specular = 1;
      return bs;
    }
    const Frame lobe = frameFromNormal(r);
    bs.wi = normalize(toWorld(&lobe, samplePhongLobe(u, n)));
    bs.pdf = bsdfPdf(m, wo, bs.wi);
    bs.f = bsdfEval(m, wo, bs.wi);
    return bs;
  }
  // Metal: GGX by visible normals; below kMinGgxAlpha the mirror with Schlick's Fresnel.
  const int flip = wo.z < 0.0f;
  const float3 o = upper(wo, flip);
  if (m->roughness < kMinGgxAlpha) {
    bs.wi = r;
    bs.f = schlickFresnel(m->color, o.z) / fabs(r.z);
    bs.pdf = 1.0f;
    bs.specular = 1;
    return bs;
  }
  const float3 h = sampleGgxVisibleNormal(o, m->roughness, u);
  const float3 i = 2.0f * dot(o, h) * h - o;
  if (!(i.z > 0.0f))
    return bs;
  bs.wi = upper(i, flip);
  bs.pdf = bsdfPdf(m, wo, bs.wi);
  bs.f = bsdfEval(m, wo, bs.wi);
  return bs;
}

// ---- Light sampling (scene/light_sampling.h): lights chosen by power; spheres by their cone, triangles by area ----

float misWeight(int power, float p, float q)
{
  if (!(p > 0.0f))
    return 0.0f;
  if (isinf(p))
    return isinf(q) ? 0.5f : 1.0f;
  const float ratio = q / p;
  return power ? 1.0f / (1.0f + ratio * ratio) : 1.0f / (1.0f + ratio);
}

float oneMinusCosConeAngle(float sin2ThetaMax)
{
  const float s2 = clamp(sin2ThetaMax, 0.0f, 1.0f);
  return s2 / (1.0f + sqrt(1.0f - s2));
}

float sphereConePdf(float3 ref, float3 c, float r)
{
  const float3 toCentre = c - ref;
  const float d2 = dot(toCentre, toCentre);
  if (d2 <= r * r)
    return 1.0f / (4.0f * kPi);
  return 1.0f / (2.0f * kPi * oneMinusCosConeAngle(r * r / d2));
}

float3 sampleSphereCone(float3 ref, float3 c, float r, float2 u)
{
  const float3 toCentre = c - ref;
  const float d2 = dot(toCentre, toCentre);
  const float2 phi = sinCos2Pi(u.y);
  if (d2 <= r * r) { // inside: the whole sphere of directions
    const float z = 1.0f - 2.0f * u.x;
    const float s = sqrt(fmax(0.0f, (1.0f - z) * (1.0f + z)));
    return (float3)(s * phi.y, s * phi.x, z);
  }
  const float oneMinusCos = u.x * oneMinusCosConeAngle(r * r / d2);
  const float cosTheta = 1.0f - oneMinusCos;
  const float sinTheta = sqrt(fmax(0.0f, oneMinusCos * (2.0f - oneMinusCos)));
  const Frame axis = frameFromNormal(toCentre / sqrt(d2));
  return normalize(sinTheta * phi.y * axis.s + sinTheta * phi.x * axis.t + cosTheta * axis.n);
}

// The solid-angle density of choosing the point `p` uniformly on a triangle of `area`, normal `n`, seen from `ref`.
float triangleAreaPdf(float3 ref, float3 p, float3 n, float area)
{
  const float3 toPoint = p - ref;
  const float d2 = dot(toPoint, toPoint);
  const float cosine = fabs(dot(n, toPoint)) / sqrt(d2);
  return cosine > 0.0f && area > 0.0f ? d2 / (area * cosine) : 0.0f;
}

// The lights as the host packs them: per light (kind, primitive or point light, 0, 0), its cdf entry, and per
// primitive the probability of choosing it (0 for a primitive that does not emit).
#define kPointLight 0
#define kSphereLight 1
#define kTriangleLight 2

typedef struct {
  __global const int4* info;
  __global const float* cdf;
  __global const float* probability;  // per primitive
  __global const float4* pointLights; // position, then intensity
  int count;
} Lights;

// The light whose cdf entry is the first above u (std::upper_bound), and the probability of choosing it.
int chooseLight(const Lights* l, float u, float* choice)
{
  int lo = 0, hi = l->count - 1;
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (l->cdf[mid] > u)
      hi = mid;
    else
      lo = mid + 1;
  }
  *choice = l->cdf[lo] - (lo > 0 ? l->cdf[lo - 1] : 0.0f);
  return lo;
}

// The density (solid angle, at `ref`) with which light sampling would have chosen `point` on emitter `p`.
float lightPdf(const Geometry* g, const Lights* l, float3 ref, int p, float3 point)
{
  const float choice = l->probability[p];
  if (!(choice > 0.0f))
    return 0.0f;
  if (p < g->sphereCount) {
    const float4 s = g->spheres[p];
    return choice * sphereConePdf(ref, s.xyz, s.w);
  }
  const uint4 tri = g->triangles[p - g->sphereCount];
  const float3 p0 = vertexAt(g, tri.x), p1 = vertexAt(g, tri.y), p2 = vertexAt(g, tri.z);
  return choice * triangleAreaPdf(ref, point, triangleNormal(p0, p1, p2), length(cross(p1 - p0, p2 - p0)) / 2.0f);
}

// A light sample at a surface point: direction, radiance or irradiance arriving, pdf (0: none), the shadow ray's
// length, and whether it is a point light (a delta: MIS weight 1).
typedef struct {
  float3 wi, Li, origin;
  float pdf, tmax;
  int delta;
} LightSample;

LightSample sampleLight(const Geometry* g, const Lights* l, __global const float4* materials, float3 point,
                        float3 error, float3 geometricNormal, float uLight, float2 u)
{
  LightSample ls;
  ls.pdf = 0.0f;
  ls.delta = 0;
  ls.wi = (float3)(0.0f, 0.0f, 1.0f);
  ls.Li = (float3)(0.0f);
  ls.origin = point;
  ls.tmax = 0.0f;
  float choice;
  const int k = chooseLight(l, uLight, &choice);
  const int4 info = l->info[k];
  if (info.x == kPointLight) {
    const float3 position = l->pointLights[2 * info.y].xyz;
    const float3 toLight = position - point;
    const float distance = length(toLight);
    if (!(distance > 0.0f))
      return ls;
    ls.wi = toLight / distance;
    ls.Li = l->pointLights[2 * info.y + 1].xyz / (distance * distance);
    ls.pdf = choice;
    ls.delta = 1;
    // spawnRayTo: stop just short of the light.
    ls.origin = offsetRayOrigin(point, error, geometricNormal, ls.wi);
    ls.tmax = length(position - ls.origin) * (1.0f - kShadowRayShorten);
    return ls;
  }
  const int p = info.y;
  if (info.x == kSphereLight) {
    const float4 s = g->spheres[p];
    ls.wi = sampleSphereCone(point, s.xyz, s.w, u);
    ls.pdf = choice * sphereConePdf(point, s.xyz, s.w);
  } else {
    const uint4 tri = g->triangles[p - g->sphereCount];
    const float3 p0 = vertexAt(g, tri.x), p1 = vertexAt(g, tri.y), p2 = vertexAt(g, tri.z);
    const float su = sqrt(u.x);
    const float3 target = (1.0f - su) * p0 + su * (1.0f - u.y) * p1 + su * u.y * p2;
    ls.wi = safeNormalize(target - point, (float3)(0.0f, 0.0f, 1.0f));
    ls.pdf = choice * triangleAreaPdf(point, target, triangleNormal(p0, p1, p2), length(cross(p1 - p0, p2 - p0)) / 2.0f);
  }
  ls.Li = materialAt(materials, materialOf(g, p)).emission;
  // The shadow ray leaves the surface and ends where it first meets the light (none: it misses by rounding).
  ls.origin = offsetRayOrigin(point, error, geometricNormal, ls.wi);
  const float t = intersectPrimitive(g, p, ls.origin, ls.wi, 0.0f, INFINITY);
  if (!(t >= 0.0f) || !(ls.pdf > 0.0f)) {
    ls.pdf = 0.0f;
    return ls;
  }
  ls.tmax = t;
  return ls;
}

// ---- A work-group's prefix sums (stream compaction: where each work-item's entries go among its group's) ---------

/// [scan]
// The sum of `value` over the work-items of the group before this one (an exclusive scan), and over the whole group
// in *total: Hillis and Steele's scan, log2(group size) steps in which each work-item adds in the partial sum that ends
// 1, 2, 4, ... places before it. `partial`: local memory for one number a work-item. Every work-item of the group
// must call it (it waits at barriers).
uint groupExclusiveScan(const uint value, __local uint* partial, uint* total)
{
  const uint k = get_local_id(0), size = get_local_size(0);
  partial[k] = value;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint offset = 1; offset < size; offset *= 2) {
    const uint earlier = k >= offset ? partial[k - offset] : 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    partial[k] += earlier;
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  *total = partial[size - 1];
  return partial[k] - value;
}
/// [scan]
