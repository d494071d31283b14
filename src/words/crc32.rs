//! CRC-32 (IEEE 802.3: reflected polynomial `0xEDB8_8320`, initial value and final XOR
//! `0xFFFF_FFFF`) over the little-endian bytes of `u32` words, one nibble at a time from a
//! 16-entry table (64 B of flash, no 1 KiB byte table). Detects every single-bit and every
//! double-bit error, and every burst of up to 32 bits, in the configuration words.

/// CRC-32 of `0 … 15` shifted through four rounds of the reflected polynomial.
const NIBBLE_TABLE: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 4 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
            k += 1;
        }
        #[allow(clippy::indexing_slicing)] // const evaluation: i < 16 by the loop
        {
            table[i] = c;
        }
        i += 1;
    }
    table
};

/// The CRC-32 of the little-endian bytes of `words`.
pub fn crc32_words(words: &[u32]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &w in words {
        for byte in w.to_le_bytes() {
            crc ^= u32::from(byte);
            for _ in 0..2 {
                // `crc & 15` < 16: the index is in range.
                let entry = NIBBLE_TABLE.get((crc & 15) as usize).copied().unwrap_or(0);
                crc = (crc >> 4) ^ entry;
            }
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_standard_check_value() {
        // "123456789" → 0xCBF43926 is the standard check value; as words: "1234", "5678", then
        // "9" alone is not a whole word, so check whole-word inputs against a bitwise reference.
        let bitwise = |bytes: &[u8]| {
            let mut crc = 0xFFFF_FFFFu32;
            for &b in bytes {
                crc ^= u32::from(b);
                for _ in 0..8 {
                    crc = if crc & 1 != 0 {
                        (crc >> 1) ^ 0xEDB8_8320
                    } else {
                        crc >> 1
                    };
                }
            }
            !crc
        };
        assert_eq!(bitwise(b"123456789"), 0xCBF4_3926);
        let words = [0x3433_3231u32, 0x3837_3635, 0xDEAD_BEEF, 0];
        let mut bytes = [0u8; 16];
        for (chunk, w) in bytes.chunks_mut(4).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        assert_eq!(crc32_words(&words), bitwise(&bytes));
        assert_eq!(crc32_words(&[]), 0);
    }
}
