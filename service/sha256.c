/*
 * sha256.c: SHA-256 through OpenSSL's libcrypto, used for the scene
 * cache's content keys (a collision would hand one client another
 * client's scene, so the hash must be strong) and for comparing the bearer
 * token in constant time.
 */
#include "lensrayd.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <string.h>

void lrd_sha256(const void *data, size_t len, unsigned char out[32])
{
    unsigned int n = 0;
    /* EVP_Digest only fails on allocation failure inside OpenSSL; a zero
     * key then can only miss the cache (every real key is a digest), and
     * for the token it makes the comparison fail, which is safe. */
    if (EVP_Digest(data, len, out, &n, EVP_sha256(), NULL) != 1 || n != 32)
        memset(out, 0, 32);
}

int lrd_secret_equal(const void *a, size_t alen, const void *b, size_t blen)
{
    /* Hash both sides first, so the comparison takes the same time
     * whatever the lengths, then compare the digests in constant time
     * (OpenSSL's CRYPTO_memcmp does not stop at the first difference). */
    unsigned char ha[32], hb[32];
    lrd_sha256(a, alen, ha);
    lrd_sha256(b, blen, hb);
    return CRYPTO_memcmp(ha, hb, 32) == 0;
}
