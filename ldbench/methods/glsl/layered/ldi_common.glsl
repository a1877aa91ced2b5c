// Shared by the LDI build passes: float depth <-> order-preserving uint (a < b as floats iff
// ldi_order(a) < ldi_order(b) as uints, for finite values; -0.0 sorts just below +0.0).
#ifndef LDBENCH_LDI_COMMON_GLSL
#define LDBENCH_LDI_COMMON_GLSL
uint ldi_order(float x) {
    uint u = floatBitsToUint(x);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}
float ldi_unorder(uint o) {
    return uintBitsToFloat((o & 0x80000000u) != 0u ? (o & 0x7FFFFFFFu) : ~o);
}
#define LDI_NONE 0xFFFFFFFFu
#endif
