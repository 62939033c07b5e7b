//! The hidden helper roles of `vbap bench` (`--role ...`): this executable as the peer of a
//! floor, the skeleton or the fan-out.

use anyhow::Result;
use vbap_ipc::process::InvalidInput;
use vbap_ipc::topics::Domain;

use super::args::{BenchArgs, Role};
use super::{fanout, floors, skeleton, skeleton_hosts};

/// Runs a helper role (a peer process of a floor).
pub fn helper(role: Role, args: &BenchArgs) -> Result<i32> {
    vbap_ipc::process::die_with_parent(args.parent);
    let domain = || -> Result<Domain> {
        let name = args
            .domain
            .as_deref()
            .ok_or_else(|| InvalidInput(format!("--role {role:?} needs --domain")))?;
        Ok(Domain::new(name)?)
    };
    let code = match role {
        Role::IoxPong => floors::iox_pong(&domain()?, false),
        Role::UdpPong => floors::udp_pong(false),
        Role::IoxPongPoll => floors::iox_pong(&domain()?, true),
        Role::UdpPongPoll => floors::udp_pong(true),
        Role::Spin => floors::spin(),
        Role::SkeletonAgent | Role::SkeletonField | Role::FanoutIox => {
            let (Some(id), Some(agents)) = (args.id, args.agents) else {
                return Err(
                    InvalidInput(format!("--role {role:?} needs --id and --agents")).into(),
                );
            };
            match role {
                Role::SkeletonAgent => skeleton::agent(&domain()?, id, agents),
                Role::SkeletonField => skeleton::field(&domain()?, agents),
                _ => fanout::iox_receiver(
                    &domain()?,
                    id,
                    agents,
                    args.warmup.unwrap_or(0),
                    args.rounds.unwrap_or(0),
                ),
            }
        }
        Role::SkeletonHost => {
            let (Some(domain), Some(hosts), Some(host), Some(n)) = (
                args.domain.as_deref(),
                args.hosts_file.as_deref(),
                args.host.as_deref(),
                args.agents,
            ) else {
                return Err(InvalidInput(format!(
                    "--role {role:?} needs --domain, --hosts-file, --host and --agents"
                ))
                .into());
            };
            let share = skeleton_hosts::Share {
                domain,
                hosts,
                host,
                n,
                rounds: args.rounds.unwrap_or(1000),
            };
            let Some(work) = args.work_dir.as_deref() else {
                return Err(InvalidInput("--role skeleton-host needs --work-dir".into()).into());
            };
            skeleton_hosts::host(&share, work)
        }
        Role::FanoutUdp => fanout::udp_receiver(
            args.id.unwrap_or(0),
            args.agents.unwrap_or(0),
            args.warmup.unwrap_or(0),
            args.rounds.unwrap_or(0),
        ),
        Role::WakeAgent => {
            let (Some(id), Some(agents)) = (args.id, args.agents) else {
                return Err(
                    InvalidInput("--role wake-agent needs --id and --agents".into()).into(),
                );
            };
            floors::wake_agent(&domain()?, id, agents)
        }
    }?;
    Ok(code)
}
