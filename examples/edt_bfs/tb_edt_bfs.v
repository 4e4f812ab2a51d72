// A user's testbench for the navcores EDT/BFS path planner, in plain Verilog:
// no cocotb, no Python while it runs.  The DUT is the module FuseSoC's
// navcores_edt_bfs generator emitted for an 8x8 array (edt_bfs_height8_width8;
// ports and payload fields: its manifest edt_bfs_height8_width8.json).
//
// One job: the command (d_far, start, path = 1), the image column by column
// (column 7 first), then every result beat: the path from the start to the
// goal, then every cell (distance, nearest-obstacle vector, cfr, visited,
// parent), the last beat flagged.  The sink stalls now and then; every beat
// is compared with the golden model's (stimulus.hex, expected.hex, meta.hex:
// python examples/edt_bfs/make_golden.py).  A failure ends with $fatal.
`timescale 1ns / 1ps

module tb_edt_bfs;
  localparam H = 8, W = 8;
  localparam CMD_W = 11, COL_W = 16, RES_W = 27;
  localparam MAX_BEATS = 128;
  localparam TIMEOUT = 5000;

  reg clk = 1'b0;
  reg rst = 1'b1;
  always #5 clk = ~clk;

  reg [RES_W-1:0] stimulus [0:W];          // command, then W columns
  reg [RES_W-1:0] expected [0:MAX_BEATS-1];
  reg [31:0]      meta [0:3];              // beats, EDT iterations, BFS iterations, cycles
  initial begin
    $readmemh("stimulus.hex", stimulus);
    $readmemh("expected.hex", expected);
    $readmemh("meta.hex", meta);
  end

  reg              c_valid = 1'b0;
  reg  [CMD_W-1:0] c_payload = 0;
  wire             c_ready;
  reg              i_valid = 1'b0;
  reg  [COL_W-1:0] i_payload = 0;
  wire             i_ready;
  wire             o_valid;
  wire [RES_W-1:0] o_payload;
  reg              o_ready = 1'b0;
  wire             busy, path_found, start_err;
  wire [3:0]       iterations_edt;
  wire [6:0]       iterations_bfs;

  edt_bfs_height8_width8 dut (
    .clk(clk), .rst(rst),
    .c_stream__valid(c_valid), .c_stream__ready(c_ready), .c_stream__payload(c_payload),
    .i_stream__valid(i_valid), .i_stream__ready(i_ready), .i_stream__payload(i_payload),
    .o_stream__valid(o_valid), .o_stream__ready(o_ready), .o_stream__payload(o_payload),
    .busy(busy), .iterations_edt(iterations_edt), .iterations_bfs(iterations_bfs),
    .path_found(path_found), .start_err(start_err)
  );

  integer cycle = 0, sent = 0, got = 0, errors = 0, path_beats = 0;
  integer next;
  reg finished = 1'b0;

  always @(posedge clk) begin
    cycle <= cycle + 1;
    if (rst) begin
      c_valid <= 1'b0; i_valid <= 1'b0; o_ready <= 1'b0;
    end else begin
      // Command: one beat, held until taken.
      if (sent == 0 && !c_valid) begin
        c_valid <= 1'b1;
        c_payload <= stimulus[0][CMD_W-1:0];
      end
      if (c_valid && c_ready) begin
        c_valid <= 1'b0;
      end
      // Image columns after the command, a gap after the third one.
      next = sent + ((c_valid && c_ready) || (i_valid && i_ready));
      sent <= next;
      if (!i_valid || i_ready) begin
        if (next >= 1 && next <= W && !(next == 4 && i_valid)) begin
          i_valid <= 1'b1;
          i_payload <= stimulus[next][COL_W-1:0];
        end else
          i_valid <= 1'b0;
      end
      // Results: the sink is not ready two cycles in five.
      o_ready <= (cycle % 5) > 1;
      if (o_valid && o_ready && !finished) begin
        if (o_payload !== expected[got]) begin
          errors <= errors + 1;
          $display("MISMATCH beat %0d: %h, expected %h", got, o_payload, expected[got]);
        end
        if (!o_payload[0]) path_beats <= path_beats + 1;      // field cell = bit 0
        got <= got + 1;
        if (o_payload[RES_W-1]) finished <= 1'b1;              // field last
      end
    end
  end

  initial begin
    repeat (3) @(posedge clk);
    rst <= 1'b0;
  end

  always @(posedge clk) begin
    if (finished) begin
      if (errors == 0 && got == meta[0] && iterations_edt == meta[1] && iterations_bfs == meta[2]
          && path_found && !start_err && !busy)
        $display("PASS: %0d beats (a path of %0d pixels) matched the golden model; %0d EDT + %0d BFS iterations",
                 got, path_beats, iterations_edt, iterations_bfs);
      else
        $fatal(1, "FAIL: %0d mismatches, %0d beats (expected %0d), iterations %0d/%0d (expected %0d/%0d), path_found %0d",
               errors, got, meta[0], iterations_edt, iterations_bfs, meta[1], meta[2], path_found);
      $finish;
    end
    if (cycle > TIMEOUT)
      $fatal(1, "FAIL: timeout after %0d cycles, %0d beats", cycle, got);
  end
endmodule
