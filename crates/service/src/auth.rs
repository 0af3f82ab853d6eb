//! Access tokens: configured as SHA-256 hashes, or generated at first start (printed once,
//! stored hashed). Tokens are 256-bit random strings, so a plain SHA-256 is a sufficient
//! verifier (no password stretching is needed for full-entropy secrets).

use sha2::{Digest, Sha256};

use crate::config::{Role, TokenEntry};
use crate::error::{invalid, Result};

/// A known token: its hash and role.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KnownToken {
    /// SHA-256 of the token, lowercase hex.
    pub sha256: String,
    /// Role.
    pub role: Role,
}

/// The verifier of API tokens.
#[derive(Debug, Clone, Default)]
pub struct Tokens {
    known: Vec<KnownToken>,
}

/// A freshly generated token pair (shown once).
#[derive(Debug, Clone)]
pub struct Generated {
    /// Operator token.
    pub operator: String,
    /// Read-only token.
    pub read_only: String,
}

/// SHA-256 of a token as lowercase hex.
pub fn hash_token(token: &str) -> String {
    let d = Sha256::digest(token.as_bytes());
    let mut s = String::with_capacity(64);
    for b in d.iter() {
        s.push_str(&format!("{b:02x}"));
    }
    s
}

/// A new random token with a role prefix (`gco_` operator, `gcr_` read-only).
pub fn generate_token(role: Role) -> Result<String> {
    let mut bytes = [0u8; 32];
    getrandom::getrandom(&mut bytes)
        .map_err(|e| invalid("token", e, "an operating-system random source"))?;
    let mut s = String::from(match role {
        Role::Operator => "gco_",
        Role::ReadOnly => "gcr_",
    });
    for b in bytes {
        s.push_str(&format!("{b:02x}"));
    }
    Ok(s)
}

impl Tokens {
    /// Loads the tokens kept in the record (SQLite or PostgreSQL) and the configured ones;
    /// when there are none at all, generates an operator and a read-only token, stores their
    /// hashes and returns them so they can be printed once.
    pub fn load_or_generate_in(
        store: &dyn crate::storage::Store,
        configured: &[TokenEntry],
    ) -> Result<(Self, Option<Generated>)> {
        let mut known: Vec<KnownToken> = configured
            .iter()
            .map(|t| KnownToken {
                sha256: t.sha256.clone(),
                role: t.role,
            })
            .collect();
        for (sha256, role) in store.token_hashes()? {
            if let Some(role) = Role::from_name(&role) {
                known.push(KnownToken { sha256, role });
            }
        }
        let mut generated = None;
        if known.is_empty() {
            let g = Generated {
                operator: generate_token(Role::Operator)?,
                read_only: generate_token(Role::ReadOnly)?,
            };
            for (tok, role) in [
                (&g.operator, Role::Operator),
                (&g.read_only, Role::ReadOnly),
            ] {
                let sha256 = hash_token(tok);
                store.add_token(role.name(), &sha256)?;
                known.push(KnownToken { sha256, role });
            }
            generated = Some(g);
        }
        Ok((Self { known }, generated))
    }

    /// The role of a presented token, if it is known; compares hashes in constant time.
    pub fn role_of(&self, token: &str) -> Option<Role> {
        let h = hash_token(token);
        let mut best: Option<Role> = None;
        for k in &self.known {
            if ct_eq(k.sha256.as_bytes(), h.as_bytes()) {
                best = best.max(Some(k.role));
            }
        }
        best
    }

    /// A short id for the audit log: the first 8 hex digits of the hash (never the token).
    pub fn token_id(token: &str) -> String {
        hash_token(token)[..8].to_string()
    }
}

fn ct_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    #[test]
    fn sha256_matches_fips_180_vectors() {
        // FIPS 180-2 appendix B.1 and the empty-message digest.
        assert_eq!(
            hash_token("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            hash_token(""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }

    #[test]
    fn generated_tokens_are_stored_hashed_and_verified() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("record.sqlite");
        drop(crate::storage::open(&path).unwrap());
        let store = crate::storage::SqliteStore::new(&path);
        let (tokens, generated) = Tokens::load_or_generate_in(&store, &[]).unwrap();
        let g = generated.unwrap();
        assert_eq!(tokens.role_of(&g.operator), Some(Role::Operator));
        assert_eq!(tokens.role_of(&g.read_only), Some(Role::ReadOnly));
        assert_eq!(tokens.role_of("gco_nothing"), None);
        let conn = crate::storage::open_read(&path).unwrap();
        let stored: Vec<String> = conn
            .prepare("SELECT sha256 FROM tokens")
            .unwrap()
            .query_map([], |r| r.get(0))
            .unwrap()
            .map(|r| r.unwrap())
            .collect();
        assert_eq!(stored.len(), 2);
        assert!(!stored.iter().any(|s| s == &g.operator || s == &g.read_only));
        assert!(stored.contains(&hash_token(&g.operator)));
        // Second start: nothing generated, the same tokens still work.
        let (again, none) = Tokens::load_or_generate_in(&store, &[]).unwrap();
        assert!(none.is_none());
        assert_eq!(again.role_of(&g.operator), Some(Role::Operator));
    }
}
