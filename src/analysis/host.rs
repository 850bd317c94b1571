//! The machine a measurement ran on, named in `lumen bench`'s and `lumen converge`'s
//! reports. The same binary and driver measured very differently on the hosts lumen was
//! benchmarked on (lavapipe against the CPU reference: 0.97–1.62× on a Zen 3 host with AVX2,
//! 1.11–2.58× on a Zen 4 host with AVX-512, BENCHMARKS.md), so a figure is only worth its
//! machine: the CPU model, its generation (family and model on x86-64), its logical CPUs and
//! the widest vector instructions it has.

use std::fmt;

use crate::device::OpenDevice;

/// What [`Host::detect`] found about this machine's CPU.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Host {
    /// The CPU's name ("AMD EPYC", "Intel(R) Xeon(R) Processor"), `None` where the system
    /// does not say.
    pub cpu_model: Option<String>,
    /// x86-64's CPU family and model numbers (they tell generations apart where the name
    /// does not: AMD family 25 is Zen 3 at model 1, Zen 4 at model 17).
    pub family_model: Option<(u32, u32)>,
    /// Logical CPUs this process may use.
    pub logical_cpus: usize,
    /// The widest vector extension: "AVX-512", "AVX2", "SSE4.2", "NEON", or `None`.
    pub vector_isa: Option<&'static str>,
}

impl Host {
    /// This machine (on Linux from `/proc/cpuinfo`; elsewhere without the name and numbers).
    pub fn detect() -> Self {
        let (cpu_model, family_model) =
            std::fs::read_to_string("/proc/cpuinfo").map(|text| parse_cpuinfo(&text)).unwrap_or((None, None));
        Host {
            cpu_model,
            family_model,
            logical_cpus: std::thread::available_parallelism().map_or(1, usize::from),
            vector_isa: vector_isa(),
        }
    }
}

impl fmt::Display for Host {
    /// ```
    /// use lumen::analysis::Host;
    /// let h = Host { cpu_model: Some("AMD EPYC".into()), family_model: Some((25, 1)), logical_cpus: 2, vector_isa: Some("AVX2") };
    /// assert_eq!(h.to_string(), "AMD EPYC (family 25, model 1), 2 logical CPUs, AVX2");
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.cpu_model.as_deref().unwrap_or("unknown CPU"))?;
        if let Some((family, model)) = self.family_model {
            write!(f, " (family {family}, model {model})")?;
        }
        let s = if self.logical_cpus == 1 { "" } else { "s" };
        write!(f, ", {} logical CPU{s}", self.logical_cpus)?;
        if let Some(isa) = self.vector_isa {
            write!(f, ", {isa}")?;
        }
        Ok(())
    }
}

/// The line `lumen bench` and `lumen converge` put in their reports: this machine and, for
/// a GPU among `devices`, its backend and driver (both move the figures: BENCHMARKS.md
/// compares hosts and Mesa versions).
pub fn machine_line(devices: &[OpenDevice]) -> String {
    let drivers: Vec<String> = devices.iter().filter_map(OpenDevice::driver).collect();
    let mut line = format!("Machine: {}", Host::detect());
    if !drivers.is_empty() {
        line.push_str(&format!("; GPU driver: {}", drivers.join(", ")));
    }
    line.push('.');
    line
}

/// The first processor's name and, on x86-64, its family and model, from the text of
/// Linux's `/proc/cpuinfo` (`model name`, `cpu family`, `model`; where `model name` is
/// missing, as on some Arm kernels, `Hardware` names the machine).
pub fn parse_cpuinfo(text: &str) -> (Option<String>, Option<(u32, u32)>) {
    // A key's first line: the first processor's (every processor repeats its block).
    let field = |key: &str| -> Option<&str> {
        text.lines()
            .find_map(|l| l.split_once(':').filter(|(k, _)| k.trim() == key).map(|(_, v)| v.trim()))
            .filter(|v| !v.is_empty())
    };
    let name =
        field("model name").or_else(|| field("Hardware")).map(|n| n.split_whitespace().collect::<Vec<_>>().join(" "));
    let number = |key: &str| field(key).and_then(|v| v.parse::<u32>().ok());
    let family_model = number("cpu family").zip(number("model"));
    (name, family_model)
}

/// The widest vector extension this CPU runs (detected at run time). A description, not
/// `cli::software_driver::host_vector_bits`, which picks llvmpipe's width and asks more of
/// an AVX-512 core before it chooses 512 bits.
fn vector_isa() -> Option<&'static str> {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f") && has!("avx512vl") {
            return Some("AVX-512");
        }
        if has!("avx2") {
            return Some("AVX2");
        }
        if has!("sse4.2") {
            return Some("SSE4.2");
        }
        None
    }
    #[cfg(target_arch = "aarch64")]
    {
        Some("NEON")
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // The first two processors of a 2-core AMD EPYC VM's /proc/cpuinfo, abridged by hand.
    const EPYC: &str = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 1\n\
model name\t: AMD EPYC   Processor\nstepping\t: 1\nflags\t\t: fpu vme avx2\n\n\
processor\t: 1\nvendor_id\t: AuthenticAMD\ncpu family\t: 26\nmodel\t\t: 2\nmodel name\t: Other\n";

    #[test]
    fn the_first_processor_names_the_machine() {
        let (name, fm) = parse_cpuinfo(EPYC);
        assert_eq!(name.as_deref(), Some("AMD EPYC Processor"));
        assert_eq!(fm, Some((25, 1)));
    }

    #[test]
    fn arm_and_empty_listings_leave_out_what_they_lack() {
        let arm = "processor\t: 0\nBogoMIPS\t: 50.00\nCPU part\t: 0xd0c\n\nHardware\t: Example SoC\n";
        assert_eq!(parse_cpuinfo(arm), (Some("Example SoC".into()), None));
        assert_eq!(parse_cpuinfo(""), (None, None));
        // A family without a model (or a value that is not a number) gives no pair.
        assert_eq!(parse_cpuinfo("cpu family\t: 6\nmodel\t\t: x\n").1, None);
    }

    #[test]
    fn display_names_what_is_known() {
        let h = Host { cpu_model: None, family_model: None, logical_cpus: 1, vector_isa: None };
        assert_eq!(h.to_string(), "unknown CPU, 1 logical CPU");
        let d = Host::detect();
        assert!(d.logical_cpus >= 1);
        assert!(d.to_string().contains("logical CPU"));
    }
}
