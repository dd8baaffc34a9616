/* Minimal reproducer of a compiler bug in Intel's OpenCL CPU runtime (PyPI intel-opencl-rt
 * 2026.2.0, driver 2026.22.10.0.01_160000), the cause of the low-pass tables that differed from
 * run to run (issue 33; cl/sat_build.cl segment_optical_depth takes float4 because of it).
 *
 * A function that is not inlined and takes a float3 by value, called from a kernel that Intel's
 * vectoriser turns into 16 work-items per SIMD lane set: the vectorised copy of the function
 * (_ZGVeN16vv_f in CL_CONFIG_DUMP_DISASSEMBLY=True's listing) reads its float3 arguments wrongly:
 * on an AVX-512 machine lane 0 gets the right value, the other 15 garbage that changes between
 * runs. The same kernel with float4 arguments is right, and so is the float3 one with the
 * vectoriser off (CL_CONFIG_CPU_VECTORIZER_MODE=1) or on PoCL. A struct of three floats by value
 * is right too. Nothing in the kernel is undefined: float3 function arguments are plain OpenCL C.
 * (In sombra the function is out of line because two kernels of the program call it.)
 *
 *   cc tests/portability/intel_float3_call.c -o intel_float3_call -lOpenCL
 *   OCL_ICD_VENDORS=$(scripts/intel-opencl.sh) LD_PRELOAD=.intel-opencl/lib/libtbb.so.12 ./intel_float3_call
 *
 * Uses the first device of the first platform. Exit 1 when a wrong value was seen, 0 otherwise. */
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <stdio.h>
#include <stdlib.h>
#define CHECK(x) do { cl_int e_ = (x); if (e_) { fprintf(stderr, "%s: error %d\n", #x, e_); exit(2); } } while (0)

static const char* source =
    "static __attribute__((noinline)) float f(TYPE a, TYPE b) { return a.x + 2.0f * a.y + 4.0f * a.z + 8.0f * b.x + 16.0f * b.y + 32.0f * b.z; }\n"
    "__kernel void k(__global float* out, int n) {\n"
    "    int i = get_global_id(0);\n"
    "    if (i >= n) return;\n"
    "    for (int r = 0; r < 8; ++r) {\n"
    "        TYPE a = (TYPE)(i, r, 1.0f EXTRA), b = (TYPE)(2.0f, r, i EXTRA);\n"
    "        out[i * 8 + r] = f(a, b);\n"
    "    }\n"
    "}\n";

int main(void) {
    cl_platform_id platform; cl_device_id device; cl_int err;
    CHECK(clGetPlatformIDs(1, &platform, NULL));
    CHECK(clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL));
    char name[256], driver[256];
    clGetDeviceInfo(device, CL_DEVICE_NAME, sizeof name, name, NULL);
    clGetDeviceInfo(device, CL_DRIVER_VERSION, sizeof driver, driver, NULL);
    printf("%s, driver %s\n", name, driver);
    cl_context ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err); CHECK(err);
    cl_command_queue q = clCreateCommandQueue(ctx, device, 0, &err); CHECK(err);
    enum { N = 1024 };
    static float out[N * 8];
    int failed = 0;
    const char* variants[2][2] = {{"float3", "-DTYPE=float3 -DEXTRA="}, {"float4", "-DTYPE=float4 -DEXTRA=,0.0f"}};
    for (int v = 0; v < 2; ++v) {
        cl_program p = clCreateProgramWithSource(ctx, 1, &source, NULL, &err); CHECK(err);
        if (clBuildProgram(p, 1, &device, variants[v][1], NULL, NULL)) { char log[8192]; clGetProgramBuildInfo(p, device, CL_PROGRAM_BUILD_LOG, sizeof log, log, NULL); fprintf(stderr, "%s\n", log); return 2; }
        cl_kernel k = clCreateKernel(p, "k", &err); CHECK(err);
        cl_mem buffer = clCreateBuffer(ctx, CL_MEM_WRITE_ONLY, sizeof out, NULL, &err); CHECK(err);
        cl_int n = N;
        CHECK(clSetKernelArg(k, 0, sizeof buffer, &buffer)); CHECK(clSetKernelArg(k, 1, sizeof n, &n));
        size_t wrong = 0, lanes[64] = {0};
        for (int run = 0; run < 20; ++run) {
            size_t global = N;
            CHECK(clEnqueueNDRangeKernel(q, k, 1, NULL, &global, NULL, 0, NULL, NULL));
            CHECK(clEnqueueReadBuffer(q, buffer, CL_TRUE, 0, sizeof out, out, 0, NULL, NULL));
            for (int i = 0; i < N; ++i)
                for (int r = 0; r < 8; ++r) {
                    float expected = i + 2.0f * r + 4.0f * 1.0f + 8.0f * 2.0f + 16.0f * r + 32.0f * i;
                    if (out[i * 8 + r] != expected) { ++wrong; lanes[i % 16] = 1; }
                }
        }
        printf("%s arguments: %zu of %d values wrong", variants[v][0], wrong, 20 * N * 8);
        if (wrong) { printf(" (work-items i with i %% 16 ="); for (int l = 0; l < 16; ++l) if (lanes[l]) printf(" %d", l); printf(")"); }
        printf("\n");
        failed |= wrong != 0;
        clReleaseMemObject(buffer); clReleaseKernel(k); clReleaseProgram(p);
    }
    return failed;
}
