//! `rodlog`: the command line of the substation grounding-rod robot.

fn main() {
    println!("rodlog");
}
