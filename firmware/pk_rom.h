/*
 * pk_rom.h — constant data kept in program memory on targets whose flash is
 * not in the data address space (AVR: `const` data would otherwise be copied
 * into the 2-8 KB of RAM at start), and plain `const` everywhere else (on
 * Cortex-M and hosts const data already stays in flash / read-only memory).
 *
 * Data declared PK_ROM is read only through pk_rom_u8/u16/u32 or
 * pk_rom_copy; PK_ROM_STR("...") makes a string literal in program memory
 * (pass it to functions that take ROM strings). Reads are MAIN or ISR safe.
 */
#ifndef PLOTKIN_PK_ROM_H
#define PLOTKIN_PK_ROM_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__AVR__)
/* avr-gcc without avr-libc's pgmspace.h (firmware/ includes freestanding
 * headers only): the progmem attribute and the LPM instruction. The tables
 * and strings sit at the start of flash (.progmem), within the 64 KB that
 * LPM reaches on every part. */
#define PK_ROM __attribute__((__progmem__))
#define PK_ROM_STR(s) (__extension__({ static const char pk_rom_s_[] PK_ROM = (s); &pk_rom_s_[0]; }))
static inline uint8_t pk_rom_u8(const void *p)
{
    uint8_t r;
    __asm__("lpm %0, Z" : "=r"(r) : "z"(p));
    return r;
}
static inline uint16_t pk_rom_u16(const void *p)
{
    const uint8_t *b = (const uint8_t *)p;
    return (uint16_t)(pk_rom_u8(b) | (uint16_t)pk_rom_u8(b + 1) << 8);
}
static inline uint32_t pk_rom_u32(const void *p)
{
    const uint8_t *b = (const uint8_t *)p;
    return (uint32_t)pk_rom_u16(b) | (uint32_t)pk_rom_u16(b + 2) << 16;
}
static inline void pk_rom_copy(void *dst, const void *src, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    while (n-- > 0)
        *d++ = pk_rom_u8(s++);
}
#else
#define PK_ROM
#define PK_ROM_STR(s) (s)
static inline uint8_t pk_rom_u8(const void *p) { return *(const uint8_t *)p; }
static inline uint16_t pk_rom_u16(const void *p) { return *(const uint16_t *)p; }
static inline uint32_t pk_rom_u32(const void *p) { return *(const uint32_t *)p; }
static inline void pk_rom_copy(void *dst, const void *src, size_t n) { memcpy(dst, src, n); }
#endif

#endif
