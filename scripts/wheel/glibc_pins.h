/* Forced into every C and C++ unit of the wheels (their static libraries
 * included, scripts/wheel/build_deps.sh): libm's exp, exp2, log, log2 and pow
 * (and their float forms) bound to the symbol versions glibc has had since
 * 2.2.5 rather than the ones glibc 2.27/2.29 added when it dropped their SVID
 * error handling. Both versions compute with the same code (the old one is a
 * wrapper that also sets errno), so results are the same; the wheels then
 * load on glibc older than the Debian 11 that builds them (Blender's own
 * floor is 2.28). scripts/package.sh measures what every file needs. */
#if defined(__x86_64__) && defined(__linux__) && !defined(__ASSEMBLER__)
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver exp2,exp2@GLIBC_2.2.5");
__asm__(".symver log,log@GLIBC_2.2.5");
__asm__(".symver log2,log2@GLIBC_2.2.5");
__asm__(".symver pow,pow@GLIBC_2.2.5");
__asm__(".symver expf,expf@GLIBC_2.2.5");
__asm__(".symver exp2f,exp2f@GLIBC_2.2.5");
__asm__(".symver logf,logf@GLIBC_2.2.5");
__asm__(".symver log2f,log2f@GLIBC_2.2.5");
__asm__(".symver powf,powf@GLIBC_2.2.5");
#endif
