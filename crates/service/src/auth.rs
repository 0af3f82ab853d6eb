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

/// The verifier of API tokens: the configured ones and those kept in the record (which
/// `gearcomp serve --issue-token` / `--revoke-token` change; a running service picks the
/// change up with [`Tokens::reload`]).
#[derive(Debug, Default)]
pub struct Tokens {
    configured: Vec<KnownToken>,
    known: std::sync::RwLock<Vec<KnownToken>>,
}

/// A freshly generated token pair (shown once).
#[derive(Debug, Clone)]
pub struct Generated {
    /// Operator token.
    pub operator: String,
    /// Read-only token.
    pub read_only: String,
    /// The owner-only file they were written to (see [`secure_record`]).
    pub file: Option<std::path::PathBuf>,
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
        let configured: Vec<KnownToken> = configured
            .iter()
            .map(|t| KnownToken {
                sha256: t.sha256.clone(),
                role: t.role,
            })
            .collect();
        let mut known = configured.clone();
        known.extend(stored_tokens(store)?);
        let mut generated = None;
        if known.is_empty() {
            let g = Generated {
                operator: generate_token(Role::Operator)?,
                read_only: generate_token(Role::ReadOnly)?,
                file: None,
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
        Ok((
            Self {
                configured,
                known: std::sync::RwLock::new(known),
            },
            generated,
        ))
    }

    /// Reads the record's tokens again (issued or revoked since the start).
    pub fn reload(&self, store: &dyn crate::storage::Store) -> Result<()> {
        let mut known = self.configured.clone();
        known.extend(stored_tokens(store)?);
        match self.known.write() {
            Ok(mut k) => *k = known,
            Err(p) => *p.into_inner() = known,
        }
        Ok(())
    }

    /// The role of a presented token, if it is known; compares hashes in constant time.
    pub fn role_of(&self, token: &str) -> Option<Role> {
        let h = hash_token(token);
        let mut best: Option<Role> = None;
        let known = match self.known.read() {
            Ok(k) => k,
            Err(p) => p.into_inner(),
        };
        for k in known.iter() {
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

fn stored_tokens(store: &dyn crate::storage::Store) -> Result<Vec<KnownToken>> {
    Ok(store
        .token_hashes()?
        .into_iter()
        .filter_map(|(sha256, role)| Role::from_name(&role).map(|role| KnownToken { sha256, role }))
        .collect())
}

/// Writes a secret into a new file readable by its owner only (mode 0600 on Unix); an
/// existing file is never overwritten.
pub fn write_secret_file(path: &std::path::Path, text: &str) -> Result<()> {
    use std::io::Write;
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.mode(0o600);
    }
    let io = |source| crate::error::ServiceError::Io {
        action: "create (owner-only, never overwritten)",
        path: path.display().to_string(),
        source,
    };
    let mut f = o.open(path).map_err(io)?;
    f.write_all(text.as_bytes()).map_err(io)?;
    f.sync_all().map_err(io)?;
    Ok(())
}

/// Makes an existing file readable by its owner only (mode 0600 on Unix; a no-op
/// elsewhere).
pub fn restrict_file(path: &std::path::Path) -> Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        if path.exists() {
            std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600)).map_err(
                |source| crate::error::ServiceError::Io {
                    action: "restrict to the owner",
                    path: path.display().to_string(),
                    source,
                },
            )?;
        }
    }
    #[cfg(not(unix))]
    let _ = path;
    Ok(())
}

/// At start: the SQLite record (and its WAL files) made owner-only, and tokens generated
/// at this first start written once into the new owner-only file `<storage.path>.tokens`
/// (`<storage.path>.<unix seconds>.tokens` if that exists; never overwritten).
pub fn secure_record(
    cfg: &crate::config::ServiceConfig,
    generated: Option<&mut Generated>,
) -> Result<()> {
    if cfg.storage.backend == crate::config::StorageBackend::Sqlite {
        for suffix in ["", "-wal", "-shm"] {
            let mut p = cfg.storage.path.clone().into_os_string();
            p.push(suffix);
            restrict_file(std::path::Path::new(&p))?;
        }
    }
    if let Some(g) = generated {
        let mut file = cfg.storage.path.clone().into_os_string();
        file.push(".tokens");
        let mut file = std::path::PathBuf::from(file);
        if file.exists() {
            let mut f = cfg.storage.path.clone().into_os_string();
            f.push(format!(".{}.tokens", crate::storage::unix_now_s() as u64));
            file = f.into();
        }
        write_secret_file(
            &file,
            &token_file_text(&[
                (Role::Operator, &g.operator),
                (Role::ReadOnly, &g.read_only),
            ]),
        )?;
        g.file = Some(file);
    }
    Ok(())
}

/// The text of a token file: one `role token` line per token.
pub fn token_file_text(tokens: &[(Role, &str)]) -> String {
    let mut s =
        String::from("# gearcomp API tokens (shown once; the record keeps only their SHA-256)\n");
    for (role, t) in tokens {
        s.push_str(&format!("{} {t}\n", role.name()));
    }
    s
}

/// Issues a new token of `role`: written once into the new owner-only file `file`, its
/// hash stored in the record. Returns the token's id (first 8 hex digits of its hash, as
/// the audit log names it).
pub fn issue_token(
    store: &dyn crate::storage::Store,
    role: Role,
    file: &std::path::Path,
) -> Result<String> {
    let token = generate_token(role)?;
    // The file first: a token whose file could not be written is never valid.
    write_secret_file(file, &token_file_text(&[(role, &token)]))?;
    store.add_token(role.name(), &hash_token(&token))?;
    Ok(Tokens::token_id(&token))
}

/// Revokes the record's tokens with this id (8…64 hex digits of the hash); returns how
/// many. A running service refuses them within a second.
pub fn revoke_token(store: &dyn crate::storage::Store, id: &str) -> Result<usize> {
    let id = id.trim().to_ascii_lowercase();
    if id.len() < 8 || id.len() > 64 || !id.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(invalid(
            "--revoke-token",
            &id,
            "a token id: 8…64 hex digits of its SHA-256 (as --list-tokens and the audit log show)",
        ));
    }
    let n = store.remove_token(&id)?;
    if n == 0 {
        let ids: Vec<String> = list_tokens(store)?.into_iter().map(|(i, _)| i).collect();
        let ids = if ids.is_empty() {
            "none are left".to_string()
        } else {
            ids.join(", ")
        };
        return Err(invalid(
            "--revoke-token",
            &id,
            format!("the id of a token in the record ({ids})"),
        ));
    }
    Ok(n)
}

/// The record's tokens: (id, role), oldest first.
pub fn list_tokens(store: &dyn crate::storage::Store) -> Result<Vec<(String, Role)>> {
    Ok(stored_tokens(store)?
        .into_iter()
        .map(|k| (k.sha256[..8.min(k.sha256.len())].to_string(), k.role))
        .collect())
}

fn ct_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The names a client certificate carries, read from its DER (X.509, RFC 5280 §4.1.2.6
/// subject and §4.2.1.6 subject alternative name): every subject common name (CN,
/// OID 2.5.4.3) and every DNS name of the subjectAltName extension (OID 2.5.29.17).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CertNames {
    /// Subject common names (UTF8String, PrintableString, IA5String or BMPString).
    pub common_names: Vec<String>,
    /// dNSName entries of the subject alternative names.
    pub dns_names: Vec<String>,
}

impl CertNames {
    /// The name shown in the audit log: the first CN, else the first DNS name.
    pub fn shown(&self) -> String {
        self.common_names
            .first()
            .or(self.dns_names.first())
            .cloned()
            .unwrap_or_else(|| "(no CN or DNS name)".into())
    }

    /// The role of this certificate under `http.tls.client_roles`: the highest role of
    /// the entries naming its CN or one of its DNS names (ASCII case-insensitive), with the
    /// name that matched.
    pub fn role(&self, roles: &[crate::config::ClientRole]) -> Option<(String, Role)> {
        let mut best: Option<(String, Role)> = None;
        for r in roles {
            let hit = self
                .common_names
                .iter()
                .chain(&self.dns_names)
                .any(|n| n.eq_ignore_ascii_case(&r.name));
            if hit && best.as_ref().is_none_or(|(_, b)| r.role > *b) {
                best = Some((r.name.clone(), r.role));
            }
        }
        best
    }
}

/// A subject attribute's value as text: UTF8String, PrintableString, IA5String (RFC 5280
/// §4.1.2.4 DirectoryString and the IA5String some CAs write) or BMPString (UCS-2); None for
/// other string types (TeletexString, …) or invalid text. PrintableString and IA5String are
/// read as UTF-8 without their character-set check, as before the reader used x509-cert: a
/// CA that wrote `_` or `*` into a PrintableString still names the client it signed.
fn directory_text(value: &x509_cert::der::Any) -> Option<String> {
    use x509_cert::der::{asn1::BmpString, Tag, Tagged};
    match value.tag() {
        Tag::Utf8String => value.decode_as::<String>().ok(),
        Tag::PrintableString | Tag::Ia5String => {
            std::str::from_utf8(value.value()).ok().map(str::to_string)
        }
        Tag::BmpString => BmpString::from_ucs2(value.value())
            .ok()
            .map(|s| s.to_string()),
        _ => None,
    }
}

/// The subject CNs and DNS subject alternative names of an X.509 certificate (DER, decoded
/// with RustCrypto's `x509-cert`), or None when it is not a certificate (truncated, damaged,
/// a malformed subjectAltName or a dNSName that is no IA5String). The certificate has
/// already been verified against the plant CA by rustls; this only reads the names.
pub fn certificate_names(der: &[u8]) -> Option<CertNames> {
    use x509_cert::der::{oid::AssociatedOid, oid::ObjectIdentifier, Decode};
    /// id-at-commonName (X.520, RFC 4519 §2.3).
    const CN: ObjectIdentifier = ObjectIdentifier::new_unwrap("2.5.4.3");
    use x509_cert::ext::pkix::{name::GeneralName, SubjectAltName};
    let cert = x509_cert::Certificate::from_der(der).ok()?;
    let tbs = &cert.tbs_certificate;
    let mut names = CertNames::default();
    for atv in tbs.subject.0.iter().flat_map(|rdn| rdn.0.iter()) {
        if atv.oid == CN {
            // A CN in a string type not read here (TeletexString, …) matches nothing.
            if let Some(t) = directory_text(&atv.value) {
                names.common_names.push(t);
            }
        }
    }
    for ext in tbs.extensions.iter().flatten() {
        if ext.extn_id != SubjectAltName::OID {
            continue;
        }
        let san = SubjectAltName::from_der(ext.extn_value.as_bytes()).ok()?;
        for name in san.0 {
            if let GeneralName::DnsName(dns) = name {
                names.dns_names.push(dns.to_string());
            }
        }
    }
    Some(names)
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

    #[test]
    fn issued_tokens_live_in_an_owner_only_file_and_revoke_while_running() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("record.sqlite");
        drop(crate::storage::open(&path).unwrap());
        let store = crate::storage::SqliteStore::new(&path);
        let (tokens, g) = Tokens::load_or_generate_in(&store, &[]).unwrap();
        let g = g.unwrap();
        let file = dir.path().join("op2.token");
        let id = issue_token(&store, Role::Operator, &file).unwrap();
        let text = std::fs::read_to_string(&file).unwrap();
        let tok = text
            .lines()
            .nth(1)
            .unwrap()
            .strip_prefix("operator ")
            .unwrap();
        // The id is the first 8 hex digits of the token's SHA-256 (FIPS 180-4 digest).
        assert_eq!(id, hash_token(tok)[..8]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&file).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o600);
        }
        // Never overwritten: a second issue into the same file is refused, nothing stored.
        assert!(issue_token(&store, Role::ReadOnly, &file).is_err());
        assert_eq!(list_tokens(&store).unwrap().len(), 3);
        // The running verifier sees the new token after a reload, and not after revoking.
        assert_eq!(tokens.role_of(tok), None);
        tokens.reload(&store).unwrap();
        assert_eq!(tokens.role_of(tok), Some(Role::Operator));
        assert_eq!(revoke_token(&store, &id).unwrap(), 1);
        tokens.reload(&store).unwrap();
        assert_eq!(tokens.role_of(tok), None);
        assert_eq!(tokens.role_of(&g.read_only), Some(Role::ReadOnly));
        // Bad ids: too short (would match many) or unknown, named with the option.
        let e = revoke_token(&store, "ab").unwrap_err().to_string();
        assert!(e.contains("--revoke-token"), "{e}");
        let e = revoke_token(&store, &id).unwrap_err().to_string();
        assert!(
            e.contains("--revoke-token") && e.contains(&Tokens::token_id(&g.operator)),
            "{e}"
        );
    }

    /// A certificate from rcgen (an independent X.509 writer) with the given subject
    /// attributes and subject alternative names (an address becomes an IP SAN).
    fn cert_der(cns: &[rcgen::DnValue], sans: &[String]) -> Vec<u8> {
        let key = rcgen::KeyPair::generate().unwrap();
        let mut p = rcgen::CertificateParams::new(sans.to_vec()).unwrap();
        p.distinguished_name
            .push(rcgen::DnType::OrganizationName, "gear works");
        for cn in cns {
            p.distinguished_name
                .push(rcgen::DnType::CommonName, cn.clone());
        }
        p.self_signed(&key).unwrap().der().to_vec()
    }

    #[test]
    fn certificate_names_read_what_rcgen_wrote() {
        let der = cert_der(
            &[rcgen::DnValue::Utf8String("hmi-cell-3 Prüfplatz".into())],
            &[
                "hmi3.plant.local".into(),
                "10.0.0.3".into(),
                "op-panel".into(),
            ],
        );
        let n = certificate_names(&der).unwrap();
        assert_eq!(n.common_names, ["hmi-cell-3 Prüfplatz"]);
        // The IP address SAN is no DNS name.
        assert_eq!(n.dns_names, ["hmi3.plant.local", "op-panel"]);
        // PrintableString and BMPString common names; no SAN extension at all.
        let der = cert_der(
            &[rcgen::DnValue::PrintableString(
                rcgen::string::PrintableString::try_from("viewer 7").unwrap(),
            )],
            &[],
        );
        assert_eq!(
            certificate_names(&der).unwrap(),
            CertNames {
                common_names: vec!["viewer 7".into()],
                dns_names: vec![]
            }
        );
        let der = cert_der(
            &[rcgen::DnValue::BmpString(
                rcgen::string::BmpString::try_from("Schleifmaschine Ω").unwrap(),
            )],
            &[],
        );
        assert_eq!(
            certificate_names(&der).unwrap().common_names,
            ["Schleifmaschine Ω"]
        );
        // IA5String is read; a TeletexString CN is not (it matches nothing), the other
        // CN of the same subject still is.
        let der = cert_der(
            &[
                rcgen::DnValue::TeletexString(
                    rcgen::string::TeletexString::try_from("t61 name").unwrap(),
                ),
                rcgen::DnValue::Ia5String(
                    rcgen::string::Ia5String::try_from("cell-9@plant").unwrap(),
                ),
            ],
            &["cell9.plant.local".into()],
        );
        let n = certificate_names(&der).unwrap();
        assert_eq!(n.common_names, ["cell-9@plant"]);
        assert_eq!(n.dns_names, ["cell9.plant.local"]);
    }

    #[test]
    fn nonconforming_printable_string_cn_is_still_read() {
        // Some CAs write `_` into a PrintableString (outside its X.680 character set); the
        // name is read as written. The DER is rcgen's with the one byte changed in place
        // (same length, so every enclosing length stays right; the signature is not checked
        // here, rustls has done that). Self-signed: the issuer carries the same name
        // first, the subject's is the last one.
        let mut der = cert_der(
            &[rcgen::DnValue::PrintableString(
                rcgen::string::PrintableString::try_from("viewer 7").unwrap(),
            )],
            &[],
        );
        let at = der
            .windows(10)
            .rposition(|w| w == b"\x13\x08viewer 7")
            .unwrap();
        der[at + 8] = b'_';
        assert_eq!(certificate_names(&der).unwrap().common_names, ["viewer_7"]);
    }

    #[test]
    fn not_a_certificate_is_none() {
        assert_eq!(certificate_names(&[]), None);
        assert_eq!(certificate_names(b"-----BEGIN CERTIFICATE-----"), None);
        let der = cert_der(
            &[rcgen::DnValue::Utf8String("cell".into())],
            &["a.b".into()],
        );
        // Cut anywhere inside: never a certificate.
        for cut in [1, 4, der.len() / 2, der.len() - 1] {
            assert_eq!(certificate_names(&der[..cut]), None, "cut at {cut}");
        }
    }

    #[test]
    fn certificate_role_is_the_highest_role_naming_it() {
        use crate::config::ClientRole;
        let n = CertNames {
            common_names: vec!["HMI-Cell-3".into()],
            dns_names: vec!["hmi3.plant.local".into()],
        };
        let roles = [
            ClientRole {
                name: "hmi-cell-3".into(),
                role: Role::ReadOnly,
            },
            ClientRole {
                name: "HMI3.plant.local".into(),
                role: Role::Operator,
            },
            ClientRole {
                name: "other".into(),
                role: Role::Operator,
            },
        ];
        assert_eq!(
            n.role(&roles),
            Some(("HMI3.plant.local".to_string(), Role::Operator))
        );
        assert_eq!(
            n.role(&roles[..1]),
            Some(("hmi-cell-3".into(), Role::ReadOnly))
        );
        assert_eq!(n.role(&roles[2..]), None);
        // A name is compared whole, never as a prefix or suffix.
        let short = [ClientRole {
            name: "hmi".into(),
            role: Role::Operator,
        }];
        assert_eq!(n.role(&short), None);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 24,
            failure_persistence: None,
            ..proptest::prelude::ProptestConfig::default()
        })]

        /// Random CNs (any Unicode text) and DNS names written by rcgen are read back.
        #[test]
        fn random_names_round_trip(
            cn in "\\PC{1,60}",
            dns in proptest::collection::vec("[a-z][a-z0-9-]{0,20}(\\.[a-z]{1,10}){0,3}", 0..5),
        ) {
            let der = cert_der(&[rcgen::DnValue::Utf8String(cn.clone())], &dns);
            let n = certificate_names(&der).unwrap();
            proptest::prop_assert_eq!(n.common_names, vec![cn]);
            proptest::prop_assert_eq!(n.dns_names, dns);
        }

        /// Truncated or corrupted certificates never panic the reader.
        #[test]
        fn damaged_certificates_do_not_panic(cut in 0usize..600, flip in 0usize..600, bits in 1u8..=255) {
            let mut der = cert_der(&[rcgen::DnValue::Utf8String("cell".into())], &["a.b".into()]);
            if flip < der.len() {
                der[flip] ^= bits;
            }
            der.truncate(cut.min(der.len()));
            let _ = certificate_names(&der);
        }
    }
}
