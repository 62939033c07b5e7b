//! `vbap certs HOSTS.toml --out DIR`: a mission's certificate authority and one
//! certificate per host of a hosts file, for mutual TLS between the hosts' bridges
//! (docs/guide/hosts.md). Every certificate names its host's endpoint address as subject
//! alternative name (a bridge connecting to the shore checks it) and serves both ends of
//! a link (server and client authentication). The private keys are written owner-only.
//! Prints the lines to put in the hosts file.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::Args;
use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};
use vbap_ipc::process::EXIT_OK;
use vbap_mission::hosts::Hosts;

use crate::errors::InvalidInput;

/// `vbap certs`.
#[derive(Args, Debug)]
pub struct CertsArgs {
    /// The hosts file (its endpoints give each certificate its address).
    pub hosts: PathBuf,
    /// Where to write ca.pem, ca.key and <host>.pem, <host>.key (made if missing; existing
    /// files are not overwritten).
    #[arg(long)]
    pub out: PathBuf,
    /// How long the certificates are valid, days.
    #[arg(long, default_value_t = 365)]
    pub days: u32,
}

/// Runs `vbap certs`.
pub fn main(args: &CertsArgs) -> Result<i32> {
    let endpoints = Hosts::addresses(&args.hosts).map_err(InvalidInput)?;
    if args.days == 0 {
        return Err(InvalidInput("--days must be at least 1".into()).into());
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("making {}", args.out.display()))?;
    let mut names = vec!["ca".to_string()];
    names.extend(endpoints.keys().cloned());
    for n in &names {
        for ext in ["pem", "key"] {
            let p = args.out.join(format!("{n}.{ext}"));
            if p.exists() {
                return Err(InvalidInput(format!(
                    "--out {}: {} exists (certificates are never overwritten: choose another directory)",
                    args.out.display(),
                    p.display()
                ))
                .into());
            }
        }
    }
    let now = time::OffsetDateTime::now_utc();
    let (from, to) = (
        now - time::Duration::days(1),
        now + time::Duration::days(i64::from(args.days)),
    );
    let mut ca = CertificateParams::new(Vec::<String>::new())?;
    ca.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    ca.distinguished_name
        .push(DnType::CommonName, "vbap mission CA");
    ca.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    (ca.not_before, ca.not_after) = (from, to);
    let ca_key = KeyPair::generate()?;
    let ca_cert = ca.self_signed(&ca_key)?;
    write(&args.out, "ca.pem", &ca_cert.pem(), false)?;
    write(&args.out, "ca.key", &ca_key.serialize_pem(), true)?;
    let issuer = Issuer::new(ca, ca_key);
    let dir = std::fs::canonicalize(&args.out)?;
    let quoted = |name: String| format!("{:?}", dir.join(name).display().to_string());
    println!(
        "# Add to {} (and make every endpoint tls/<address>:<port>):",
        args.hosts.display()
    );
    println!("[tls]\nca = {}", quoted("ca.pem".into()));
    for (host, address) in &endpoints {
        let mut p = CertificateParams::new(vec![address.clone()])
            .map_err(|e| anyhow!("hosts.{host}.endpoint: address {address:?}: {e}"))?;
        p.distinguished_name.push(DnType::CommonName, host.as_str());
        p.key_usages = vec![KeyUsagePurpose::DigitalSignature];
        p.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        p.use_authority_key_identifier_extension = true;
        (p.not_before, p.not_after) = (from, to);
        let key = KeyPair::generate()?;
        let cert = p.signed_by(&key, &issuer)?;
        write(&args.out, &format!("{host}.pem"), &cert.pem(), false)?;
        write(
            &args.out,
            &format!("{host}.key"),
            &key.serialize_pem(),
            true,
        )?;
        println!(
            "# in [hosts.{host}] (certificate for {address}):\ncert = {}\nkey = {}",
            quoted(format!("{host}.pem")),
            quoted(format!("{host}.key"))
        );
    }
    println!("# ca.key signs further certificates: keep it off the hosts.");
    Ok(EXIT_OK)
}

/// Writes `text` to `dir/name`, owner-only when `secret`, never over an existing file.
fn write(dir: &Path, name: &str, text: &str, secret: bool) -> Result<()> {
    use std::os::unix::fs::OpenOptionsExt;
    let path = dir.join(name);
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(if secret { 0o600 } else { 0o644 })
        .open(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    f.write_all(text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}
