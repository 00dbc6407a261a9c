/*
 * pk_rom.h — constant tables and strings in program memory, portably.
 *
 * On Arm (and the host) `const` data already stays in flash (.rodata), so
 * these macros are plain reads. On AVR, flash is a separate address space: a
 * table must be placed there with PROGMEM and read with LPM (avr-libc's
 * pgm_read_*), or it would be copied into the 2 KB of RAM at start-up.
 * (avr-gcc's __flash qualifier would read more naturally but needs GNU C;
 * the firmware is strict C11.) Architecture support only, no board code.
 *
 * Data declared PK_ROM is read only through these: PK_ROM_I8 .. PK_ROM_PTR
 * (the kernel's tables), pk_rom_u8/u16/u32 and pk_rom_copy (the protocol's
 * tables); PK_ROM_STR("...") is a string literal in program memory, for
 * functions that take ROM strings. Reads are MAIN or ISR safe.
 */
#ifndef PLOTKIN_PK_ROM_H
#define PLOTKIN_PK_ROM_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define PK_ROM PROGMEM
#define PK_ROM_I8(p) ((int8_t)pgm_read_byte(p))
#define PK_ROM_U8(p) ((uint8_t)pgm_read_byte(p))
#define PK_ROM_I16(p) ((int16_t)pgm_read_word(p))
#define PK_ROM_U16(p) ((uint16_t)pgm_read_word(p))
#define PK_ROM_I32(p) ((int32_t)pgm_read_dword(p))
#define PK_ROM_PTR(p) ((const void *)pgm_read_word(p))
#define PK_ROM_STR(s) PSTR(s)
static inline uint8_t pk_rom_u8(const void *p) { return pgm_read_byte(p); }
static inline uint16_t pk_rom_u16(const void *p) { return pgm_read_word(p); }
static inline uint32_t pk_rom_u32(const void *p) { return pgm_read_dword(p); }
static inline void pk_rom_copy(void *dst, const void *src, size_t n) { memcpy_P(dst, src, n); }
#else
#define PK_ROM
#define PK_ROM_I8(p) (*(const int8_t *)(p))
#define PK_ROM_U8(p) (*(const uint8_t *)(p))
#define PK_ROM_I16(p) (*(const int16_t *)(p))
#define PK_ROM_U16(p) (*(const uint16_t *)(p))
#define PK_ROM_I32(p) (*(const int32_t *)(p))
#define PK_ROM_PTR(p) (*(const void *const *)(p))
#define PK_ROM_STR(s) (s)
static inline uint8_t pk_rom_u8(const void *p) { return *(const uint8_t *)p; }
static inline uint16_t pk_rom_u16(const void *p) { return *(const uint16_t *)p; }
static inline uint32_t pk_rom_u32(const void *p) { return *(const uint32_t *)p; }
static inline void pk_rom_copy(void *dst, const void *src, size_t n) { memcpy(dst, src, n); }
#endif

#endif
