/* Wine 8 lacks bcryptprimitives.dll, which Windows 10 and later ship and the Rust standard
 * library of our DLLs imports (ProcessPrng, for hash seeds). For the Wine test only, this stub
 * provides it through advapi32's RtlGenRandom; it is placed next to the test driver, never in an
 * FMU. */
#include <windows.h>
#define SystemFunction036 NTAPI SystemFunction036
#include <ntsecapi.h>
#undef SystemFunction036

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len) {
    return RtlGenRandom(data, (ULONG)len);
}
