/* Oclgrind 21.10 and integer min/clamp of a vector against a scalar (OpenCL C 1.2 §6.12.3 allows
 * min(int4, int)): run `oclgrind-kernel oclgrind_min_scalar.sim`. Expected out = 2 2 2 2, 2 2 2 2,
 * 10 20 25 25; Oclgrind prints 2 0 2 0, 2 2 2 2, 10 20 0 0 (lanes 1-3 of the scalar forms take
 * whatever lies beside the scalar), so only the splat form is right. Why cl/lanes.h has lmin and lclamp. */
kernel void min_scalar(global int* out, int hi) {
    int4 v = (int4)(10, 20, 30, 40);
    vstore4(min(v, hi), 0, out);          /* the scalar form: wrong on Oclgrind 21.10 */
    vstore4(min(v, (int4)(hi)), 1, out);  /* splat: right */
    vstore4(clamp(v, hi * 5, 25), 2, out); /* the scalar form: wrong on Oclgrind 21.10 */
}
